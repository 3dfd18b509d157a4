"""How the robot's goal detector does on the twin's renders: `python -m sim.goal_survey`.

The robot's classical goal detector (jetson/perception/goals.py) runs in the full stack on the
frames the twin renders for the daemon (sim/camera.py). This survey puts one robot at random poses
on the 2v2 field (the see-saws at random tilts: level, field side down, wall side down), renders
its camera at the full stack's size, runs the detector and compares its goals with the twin's
geometric sighting (sim/goal_sight.py: the goals whose base's middle the camera sees, placed
exactly). A sighting within `match_m` of an unmatched seen goal of its colour (nearest first) is
true; one within `match_m` of a goal of its colour that the twin's sighting leaves out (its
middle out of view or hidden) is counted apart; the rest are false, each put down to what stands
where it was placed (a platform's footprint, a robot, a goal of its colour further off, or
nothing), and those of them off the platforms' footprints counted (what the scripted decider,
which drops sightings on a footprint, still passes on). It reports the counts, the true
sightings' placement error (the distance, and the error in range: negative is short) and the
blobs the shape tests turned down by reason.

    python -m sim.goal_survey --poses 300 --seed 1 [--size 240x180] [--out survey.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.geometry import robot_to_field
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.perception.camera import CameraConfig as JetsonCamera
from jetson.perception.goals import GoalDetector, GoalDetectorConfig
from sim.camera import render_camera
from sim.evaluate import eval_env
from sim.goal_sight import visible_goals
from sim.match import MatchCore
from sim.world.physics import World

COLOURS = {code: name for name, code in GOAL_COLOUR_CODES.items()}


@dataclass
class Survey:
    """The counts and errors of one survey (as_dict: the report)."""

    poses: int = 0
    seen: int = 0  # goals the twin's geometric sighting reports, over all poses
    true: int = 0
    beyond: int = 0  # at a goal of its colour that the twin's sighting leaves out (its middle
    # out of view, or hidden): right, but not counted as true
    false: Counter[str] = field(default_factory=Counter)  # by what stands there
    false_off_platforms: int = 0  # false ones yellow or not on a platform's footprint: what
    # the scripted decider, which drops the others (jetson/autonomy/goal_sightings.py), still
    # hands the strategy
    rejected: Counter[str] = field(default_factory=Counter)  # blobs turned down, by reason
    errors_m: list[float] = field(default_factory=list)  # true sightings: distance
    range_errors_m: list[float] = field(default_factory=list)  # range: found minus truth
    by_colour: dict[str, Counter[str]] = field(default_factory=dict)

    def count(self, colour: str, what: str) -> None:
        self.by_colour.setdefault(colour, Counter())[what] += 1

    def as_dict(self) -> dict[str, Any]:
        e = np.asarray(self.errors_m)
        re = np.asarray(self.range_errors_m)

        def q(values: np.ndarray, p: float) -> float | None:
            return round(float(np.quantile(values, p)), 3) if len(values) else None

        return {
            "poses": self.poses,
            "goals_seen": self.seen,
            "true": self.true,
            "beyond_the_sighting": self.beyond,
            "false": sum(self.false.values()),
            "false_by_what": dict(self.false.most_common()),
            "false_off_the_platforms": self.false_off_platforms,
            "recall": round(self.true / self.seen, 3) if self.seen else None,
            "error_m": {"median": q(e, 0.5), "p90": q(e, 0.9), "max": q(e, 1.0)},
            "range_error_m": {"p10": q(re, 0.1), "median": q(re, 0.5), "p90": q(re, 0.9)},
            "rejected_by_reason": dict(self.rejected.most_common()),
            "by_colour": {c: dict(v) for c, v in sorted(self.by_colour.items())},
        }


def survey_world(seed: int = 0) -> World:
    env = eval_env("capped", "training", world="tipping_point_2v2")
    core = MatchCore(env, replace(env.world, control_hz=50.0))
    core.reset(np.random.default_rng(seed))
    return core.world


def what_is_there(world: World, xy: np.ndarray, colour: str, index: int) -> str:
    """What stands where a false sighting was placed (field frame)."""
    for plat in world.field.platforms:
        if bool(plat.contains(np.asarray(xy))) or _near_box(plat, xy, 0.1):
            return "platform"
    for r in world.robots:
        if r.index != index and math.hypot(r.x - xy[0], r.y - xy[1]) < 0.45:
            return "robot"
    for g in world.goals:
        if _colour(g.spec.alliance) == colour and math.hypot(g.x - xy[0], g.y - xy[1]) < 1.0:
            return "goal, misplaced"
    return "nothing"


def _colour(alliance: str | None) -> str:
    return "yellow" if alliance is None else alliance


def _near_box(plat: Any, xy: np.ndarray, margin: float) -> bool:
    return (
        abs(xy[0] - plat.center[0]) <= plat.size[0] / 2 + margin
        and abs(xy[1] - plat.center[1]) <= plat.size[1] / 2 + margin
    )


def run_survey(
    poses: int,
    seed: int = 1,
    size: tuple[int, int] = (240, 180),
    match_m: float = 0.4,
    config: GoalDetectorConfig | None = None,
) -> Survey:
    world = survey_world()
    index = next(i for i, r in enumerate(world.robots) if r.alliance == "red")
    cam = world.robots[index].config.camera.scaled(*size)
    detector = GoalDetector(JetsonCamera(cam.intrinsics, cam.mount), config)
    rng = np.random.default_rng(seed)
    half = world.field.half - 0.25
    tilts = {p.alliance: (0.0, p.max_tilt_rad, -p.max_tilt_rad) for p in world.field.platforms}
    out = Survey()
    for _ in range(poses):
        for alliance, choices in tilts.items():
            world.set_tilt(alliance, float(rng.choice(choices)))
        x, y = rng.uniform(-half, half, size=2)
        world.place_robot(index, float(x), float(y), float(rng.uniform(0.0, 360.0)))
        r = world.robots[index]
        frame = render_camera(world, index, cam)
        bgr = np.ascontiguousarray(frame.rgb[:, :, ::-1])
        truth = visible_goals(world, index)
        out.poses += 1
        out.seen += len(truth)
        for row in truth:
            out.count(COLOURS[int(row[2])], "seen")
        taken = np.zeros(len(truth), dtype=bool)
        for sighting, shape in detector.blobs(bgr, frame.depth, cam.intrinsics):
            if not shape.goal:
                out.rejected[shape.why] += 1
                continue
            code = GOAL_COLOUR_CODES[sighting.colour]
            xy = np.array([sighting.x, sighting.y])
            d = np.hypot(*(truth[:, :2] - xy).T) if len(truth) else np.zeros(0)
            d = np.where((truth[:, 2] == code) & ~taken, d, np.inf) if len(truth) else d
            k = int(np.argmin(d)) if len(d) else -1
            if k >= 0 and d[k] <= match_m:
                taken[k] = True
                out.true += 1
                out.count(sighting.colour, "true")
                out.errors_m.append(float(d[k]))
                out.range_errors_m.append(float(np.hypot(*xy) - np.hypot(*truth[k, :2])))
                continue
            where = robot_to_field(xy[None, :], (r.x, r.y), r.heading)[0]
            if any(
                _colour(g.spec.alliance) == sighting.colour
                and math.hypot(g.x - where[0], g.y - where[1]) <= match_m
                for g in world.goals
            ):
                out.beyond += 1
                out.count(sighting.colour, "beyond")
                continue
            out.false[what_is_there(world, where, sighting.colour, index)] += 1
            out.false_off_platforms += sighting.colour == "yellow" or not any(
                bool(plat.contains(where)) for plat in world.field.platforms
            )
            out.count(sighting.colour, "false")
    return out


def main(argv: list[str] | None = None) -> int:
    doc = (__doc__ or "").split("\n")[0]
    ap = argparse.ArgumentParser(
        prog="python -m sim.goal_survey",
        description=doc,
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    ap.add_argument("--poses", type=int, default=300, help="random poses of the red 24in")
    ap.add_argument("--seed", type=int, default=1, help="the poses' and tilts' random seed")
    ap.add_argument("--size", default="240x180", help="the camera's size (the full stack's)")
    ap.add_argument("--match", type=float, default=0.4, help="metres: a true sighting's reach")
    ap.add_argument("--out", type=Path, help="write the report (JSON) here too")
    args = ap.parse_args(argv)
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        print(f"--size must be WIDTHxHEIGHT, got {args.size!r}", file=sys.stderr)
        return 2
    report = run_survey(args.poses, args.seed, (w, h), args.match).as_dict()
    report.update(seed=args.seed, size=f"{w}x{h}", match_m=args.match)
    text = json.dumps(report, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
