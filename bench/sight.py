"""Benchmark of what the robot sees besides rings (issue 46): mobile goals and robots, per class,
on the twin's renders, and what the detectors cost a frame on one core.

    python -m bench.sight [--scenes 1200] [--seed 0] [--results DIR] [--misses DIR] [--strict]

Each scene is the 2v2 field (sim.goal_survey.survey_world) set at random: the see-saws level or
tipped either way (as the survey), each goal at its start or moved up to `GOAL_JITTER_M` from
it, and all four robots at random poses that overlap nothing (no robot, goal base, see-saw or
wall). The red 24"'s pose is anywhere on the floor; each other robot stands, with probability
`IN_VIEW_SHARE`, somewhere in the camera's view cone `IN_VIEW_RANGE_M` from its lens, else
anywhere, and faces any way (so about a third of those ahead show their plate). The red 24"'s
camera is rendered at the full stack's 240x180 (sim.camera.render_camera) and the goal detector
(jetson/perception/goals.py) and the robot detector (jetson/perception/robots.py) run on it.

Classes: red_goal, blue_goal, neutral_goal, tall_neutral_goal (the neutral goal whose
`spec.height` is the tallest; the detector calls both neutrals yellow, a sighting takes the class
of the goal it matches), red_robot (the partner, the red 15"), blue_robot (both opponents).

The truth, within `WITHIN_M` of the lens (the floor distance to the goal's or robot's middle):
the goals the twin's geometric sighting reports (sim.goal_sight.visible_goals: the base's middle
in view, no robot in the way) and the robots whose plates its robot model sees
(sim.world.sensors.robots_in_view: a plate facing the lens, in the picture, within 2 m, not
hidden by another robot's body or a goal), each at its true middle in the robot frame. A
sighting of a colour is matched, nearest pairs first, to an unmatched truth of that colour
within `REACH_M` (sim.goal_survey's match_m): a true sighting. One left over within reach of a
goal or robot of its colour that the truth leaves out (not seen by the twin's model, or farther
than `WITHIN_M`) counts neither way (the survey's "beyond"); the rest are false (a yellow one is
put to the class of the neutral goal nearest it on the field), each put down to what stands
where it was placed (sim.goal_survey.what_is_there). Per class: precision, recall,
F1 = 2 TP / (2 TP + FP + FN), and the true sightings' localisation error (median: the distance
to the truth's middle).

Speed: the first `SPEED_FRAMES` renders are kept and the goal and robot detectors timed on them
(per frame, the mean over the set, median of 5 passes) with OpenCV on one thread and the process
pinned to one CPU (os.sched_setaffinity, so numpy's BLAS has one core too); rendering is not
timed. fps_one_core_with_rings adds the ring pipeline (jetson.perception.pipeline.Pipeline with
the classical ring detector and the goal detector) to the robot detector: the daemon's whole
perception of a 240x180 frame with goals and robots.

Targets (issue 46): F1 >= 0.95 for each class, median localisation error <= 5 cm, >= 60 frames/s
on one core for goals and robots. Results: bench/results/sight.json. sight_details.json holds,
per class, the false sightings by what stands there, the misses and the true sightings' median
error by each truth's tags (its distance band; a base or plate cut by the image's edges; over
half or in part hidden behind a robot or goal, which the twin's sightings do not check fully;
a goal next to the see-saw of its colour; how a plate faces the lens; for a missed goal, the
shape test that turned its blob down), and F1 with the truths over half hidden left out (a
diagnostic beside the target). --misses DIR writes the renders (3x, marked) of the first 60
scenes with a miss, a false sighting or a true one more than 5 cm off, and misses.json.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from bench.common import RESULTS_DIR, Result, median_ns, per_second
from jetson.autonomy.camera import project_points
from jetson.autonomy.geometry import box_corners, field_to_robot, robot_to_field
from jetson.perception.camera import CameraConfig as JetsonCamera
from jetson.perception.classical import ClassicalDetector
from jetson.perception.frame import Frame
from jetson.perception.goals import BlobShape, GoalDetector, GoalSighting
from jetson.perception.pipeline import Pipeline
from jetson.perception.robots import RobotDetector
from sim.camera import render_camera
from sim.config import CameraConfig
from sim.goal_sight import visible_goals
from sim.goal_survey import survey_world, what_is_there
from sim.visibility import in_frustum, visible
from sim.world.physics import World
from sim.world.sensors import camera_pose, obstacles, robots_in_view

GOAL_CLASSES = ("red_goal", "blue_goal", "neutral_goal", "tall_neutral_goal")
ROBOT_CLASSES = ("red_robot", "blue_robot")
CLASSES = GOAL_CLASSES + ROBOT_CLASSES
SIZE = (240, 180)  # the full stack's camera
REACH_M = 0.4  # sim.goal_survey's match_m
WITHIN_M = 2.0
GOAL_JITTER_M = 0.4  # a goal moved up to this far from its start (half the scenes' goals)
IN_VIEW_SHARE = 0.6  # of the other robots, placed in the camera's view cone
IN_VIEW_RANGE_M = (0.5, 2.4)
CLEARANCE_M = 0.03  # between any two things placed
SPEED_FRAMES = 100
F1_TARGET = 0.95
ERROR_TARGET_M = 0.05
FPS_TARGET = 60.0
BANDS_M = (1.0, 1.5, 2.0)
HIDDEN = "hidden behind a robot or goal"
NEXT_TO_M = 0.15  # misses by the truth's distance from the lens


@dataclass
class Truth:
    """One goal or robot in the scene: its class, colour, middle (robot frame), whether it counts
    (the twin sees it, within WITHIN_M), and what a miss of it is put down to."""

    cls: str
    colour: str
    xy: np.ndarray
    counted: bool
    tags: list[str] = field(default_factory=list)

    @property
    def mostly_hidden(self) -> bool:
        return f"{HIDDEN} (over half)" in self.tags


@dataclass
class Tally:
    """One class's counts over the scenes."""

    truths: int = 0
    true: int = 0
    false: int = 0
    beyond: int = 0
    errors_m: list[float] = field(default_factory=list)
    errors_by_tag: dict[str, list[float]] = field(default_factory=dict)  # true ones, by the
    # truth's tags (distance band, cut by the image, how a plate faces the lens)
    false_by_what: Counter[str] = field(default_factory=Counter)
    hidden_truths: int = 0  # truths over half hidden behind a robot or goal (the twin's robot
    # sight needs two clear points of the plate; its goal sight tests the base's middle)
    hidden_true: int = 0
    missed_by: Counter[str] = field(default_factory=Counter)

    @property
    def missed(self) -> int:
        return self.truths - self.true

    def precision(self) -> float | None:
        n = self.true + self.false
        return self.true / n if n else None

    def recall(self) -> float | None:
        return self.true / self.truths if self.truths else None

    def f1(self) -> float | None:
        n = 2 * self.true + self.false + self.missed
        return 2 * self.true / n if n else None

    def f1_not_hidden(self) -> float | None:
        """F1 with the truths over half hidden (and the sightings matched to them) left out: a
        diagnostic beside the target."""
        tp = self.true - self.hidden_true
        fn = self.missed - (self.hidden_truths - self.hidden_true)
        n = 2 * tp + self.false + fn
        return 2 * tp / n if n else None

    def median_error(self) -> float | None:
        return statistics.median(self.errors_m) if self.errors_m else None

    def as_dict(self) -> dict[str, Any]:
        e = np.asarray(self.errors_m)

        def q(p: float) -> float | None:
            return round(float(np.quantile(e, p)), 4) if len(e) else None

        return {
            "truths": self.truths,
            "true": self.true,
            "false": self.false,
            "missed": self.missed,
            "over_half_hidden": {"truths": self.hidden_truths, "true": self.hidden_true},
            "f1_not_hidden": None if (f := self.f1_not_hidden()) is None else round(f, 4),
            "beyond": self.beyond,
            "error_m": {"median": q(0.5), "p90": q(0.9), "max": q(1.0)},
            "median_error_m_by": {
                tag: {"n": len(v), "median": round(statistics.median(v), 4)}
                for tag, v in sorted(self.errors_by_tag.items())
            },
            "false_by_what": dict(self.false_by_what.most_common()),
            "missed_by": dict(self.missed_by.most_common()),
        }


def goal_classes(world: World) -> list[str]:
    """Each goal's class, in the world's goal order."""
    tallest = max((g.spec.height for g in world.goals if g.spec.alliance is None), default=0.0)
    out = []
    for g in world.goals:
        if g.spec.alliance is not None:
            out.append(f"{g.spec.alliance}_goal")
        else:
            out.append("tall_neutral_goal" if g.spec.height == tallest else "neutral_goal")
    return out


# -- the scenes --------------------------------------------------------------------------------


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two convex polygons (K, 2) overlap (separating axes), with CLEARANCE_M between."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for e in edges:
            n = np.array([-e[1], e[0]]) / max(float(np.hypot(*e)), 1e-12)
            pa, pb = a @ n, b @ n
            if pa.max() + CLEARANCE_M <= pb.min() or pb.max() + CLEARANCE_M <= pa.min():
                return False
    return True


def _box(center: Sequence[float], size: Sequence[float]) -> np.ndarray:
    """An axis-aligned rectangle's corners (4, 2)."""
    (cx, cy), (sx, sy) = center, size
    return np.array(
        [[cx - sx / 2, cy - sy / 2], [cx + sx / 2, cy - sy / 2], [cx + sx / 2, cy + sy / 2],
         [cx - sx / 2, cy + sy / 2]]
    )  # fmt: skip


def _disc_hits_box(xy: np.ndarray, radius: float, corners: np.ndarray) -> bool:
    """Whether a disc reaches into a rectangle given by its corners (4, 2), in order."""
    origin, ax, ay = corners[0], corners[1] - corners[0], corners[3] - corners[0]
    lx, ly = float(np.hypot(*ax)), float(np.hypot(*ay))
    rel = xy - origin
    px = min(max(float(rel @ ax) / lx, 0.0), lx)
    py = min(max(float(rel @ ay) / ly, 0.0), ly)
    near = origin + ax / lx * px + ay / ly * py
    return float(np.hypot(*(xy - near))) < radius + CLEARANCE_M


def place_goals(world: World, rng: np.random.Generator, starts: np.ndarray) -> None:
    """Each goal at its start, or (half of them) moved up to GOAL_JITTER_M from it; off the
    see-saws and the walls, apart from each other."""
    half = world.field.half
    plats = [_box(p.center, p.size) for p in world.field.platforms]
    for _ in range(100):
        xy = starts.copy()
        moved = rng.random(len(xy)) < 0.5
        r = GOAL_JITTER_M * np.sqrt(rng.random(len(xy)))
        a = rng.uniform(0.0, 2 * math.pi, len(xy))
        xy[moved] += np.column_stack([r * np.cos(a), r * np.sin(a)])[moved]
        radii = [g.spec.base_radius for g in world.goals]
        ok = all(
            np.all(np.abs(p) <= half - rad - CLEARANCE_M)
            and not any(_disc_hits_box(p, rad, box) for box in plats)
            for p, rad in zip(xy, radii, strict=True)
        )
        for i in range(len(xy)):
            for j in range(i):
                ok &= float(np.hypot(*(xy[i] - xy[j]))) >= radii[i] + radii[j] + CLEARANCE_M
        if ok:
            break
    else:
        xy = starts
    for g, (x, y) in zip(world.goals, xy, strict=True):
        world.place_goal(g.index, float(x), float(y))


def place_robots(world: World, rng: np.random.Generator, index: int, cam: CameraConfig) -> None:
    """The camera's robot anywhere, each other robot in the camera's view cone (IN_VIEW_SHARE of
    them) or anywhere, facing any way; none overlapping a robot placed before it, a goal's base,
    a see-saw or a wall."""
    half = world.field.half
    plats = [_box(p.center, p.size) for p in world.field.platforms]
    placed: list[np.ndarray] = []
    order = [index] + [r.index for r in world.robots if r.index != index]
    lens = None
    cone = math.radians(cam.hfov_deg / 2 + 5.0)
    for k in order:
        r = world.robots[k]
        w, length = r.config.width_m, r.config.length_m
        for tries in range(1000):
            heading = float(rng.uniform(0.0, 360.0))
            if lens is not None and tries < 200 and rng.random() < IN_VIEW_SHARE:
                me = world.robots[index]
                d = rng.uniform(*IN_VIEW_RANGE_M)
                bearing = rng.uniform(-cone, cone)
                xy = robot_to_field(
                    np.array([[d * math.sin(bearing), d * math.cos(bearing)]]), lens,
                    me.heading,
                )[0]  # fmt: skip
            else:
                xy = rng.uniform(-half, half, size=2)
            corners = box_corners(xy, heading, w, length)
            if np.any(np.abs(corners) > half - CLEARANCE_M):
                continue
            if any(_overlap(corners, other) for other in placed + plats):
                continue
            if any(
                _disc_hits_box(np.array([g.x, g.y]), g.spec.base_radius, corners)
                for g in world.goals
            ):
                continue
            break
        else:
            raise RuntimeError(f"bench.sight: no room for robot {k}")
        world.place_robot(k, float(xy[0]), float(xy[1]), heading)
        placed.append(corners)
        if k == index:
            lens = robot_to_field(np.array([[cam.right_m, cam.forward_m]]), r.xy, r.heading)[0]


def set_scene(
    world: World, rng: np.random.Generator, index: int, cam: CameraConfig, starts: np.ndarray
) -> None:
    tilts = {p.alliance: (0.0, p.max_tilt_rad, -p.max_tilt_rad) for p in world.field.platforms}
    for alliance, choices in tilts.items():
        world.set_tilt(alliance, float(rng.choice(choices)))
    place_goals(world, rng, starts)
    place_robots(world, rng, index, cam)


# -- the truth ---------------------------------------------------------------------------------


def truths(world: World, index: int, cam: CameraConfig, classes: list[str]) -> list[Truth]:
    """Every goal and every other robot, in the camera robot's frame, marked counted when the
    twin sees it within WITHIN_M of the lens; each tagged with what might hide it."""
    me = world.robots[index]
    lens = np.array([cam.right_m, cam.forward_m])
    seen_goals = visible_goals(world, index)
    pose, obs = camera_pose(world, index), obstacles(world, index)

    def hidden(pts_robot: np.ndarray) -> list[str]:
        """A tag for points (robot frame, (K, 3)) hidden behind a robot or a goal."""
        pts = np.column_stack(
            [robot_to_field(pts_robot[:, :2], me.xy, me.heading), pts_robot[:, 2]]
        )
        inside, _, _ = in_frustum(pts, pose, cam)
        if not inside.any():
            return []
        share = float(np.mean(~visible(pts, pose, cam, obs)[inside]))
        if share > 0.5:
            return [f"{HIDDEN} (over half)"]
        return [f"{HIDDEN} (in part)"] if share > 0 else []

    out = []
    for g, cls in zip(world.goals, classes, strict=True):
        xy = field_to_robot(np.array([[g.x, g.y]]), me.xy, me.heading)[0]
        seen = bool(
            len(seen_goals) and np.min(np.hypot(*(seen_goals[:, :2] - xy).T)) < 1e-6
        )  # visible_goals places a seen goal exactly: it is this one
        colour = "yellow" if g.spec.alliance is None else g.spec.alliance
        dist = float(np.hypot(*(xy - lens)))
        t = Truth(cls, colour, xy, seen and dist <= WITHIN_M)
        t.tags = [_band(dist)]
        rim = _goal_rim_cut(cam, xy, g.spec.base_radius, g.spec.base_height)
        t.tags.append(f"base cut by the image ({rim})" if rim else "base whole in the image")
        t.tags += hidden(_near_rim(cam, xy, g.spec.base_radius, g.spec.base_height))
        if _next_to_seesaw(world, g, colour):
            t.tags.append("next to the see-saw of its colour")
        out.append(t)
    in_view = robots_in_view(world)[index]
    for r in world.robots:
        if r.index == index:
            continue
        xy = field_to_robot(np.array([[r.x, r.y]]), me.xy, me.heading)[0]
        dist = float(np.hypot(*(xy - lens)))
        t = Truth(
            f"{r.alliance}_robot", r.alliance, xy, bool(in_view[r.index]) and dist <= WITHIN_M
        )
        facing = _facing_deg(me, r, lens)
        t.tags = [_band(dist), f"plate {_facing_band(facing)} to the lens"]
        cut = _plate_cut(world, index, r.index, cam)
        t.tags.append(f"plate cut by the image ({cut})" if cut else "plate whole in the image")
        t.tags += hidden(_plate_points(me, r))
        out.append(t)
    return out


def _next_to_seesaw(world: World, goal: Any, colour: str) -> bool:
    """Whether a goal's base comes within NEXT_TO_M of a see-saw of its colour (the twin's
    see-saws are red and blue): in the image the two can be one blob."""
    for plat in world.field.platforms:
        if plat.alliance != colour:
            continue
        dx = max(abs(goal.x - plat.center[0]) - plat.size[0] / 2, 0.0)
        dy = max(abs(goal.y - plat.center[1]) - plat.size[1] / 2, 0.0)
        if math.hypot(dx, dy) - goal.spec.base_radius <= NEXT_TO_M:
            return True
    return False


def _near_rim(cam: CameraConfig, xy: np.ndarray, radius: float, height: float) -> np.ndarray:
    """Points (robot frame, (K, 3)) just outside the near half of a goal base's rim (the half
    facing the lens), at half its height: what a nearer robot or goal can hide."""
    a = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
    out = np.column_stack([np.cos(a), np.sin(a)])
    near = out @ (np.array([cam.right_m, cam.forward_m]) - xy) > 0
    ring = xy + (radius + 0.02) * out[near]
    return np.column_stack([ring, np.full(len(ring), height / 2)])


def _plate_points(me: Any, other: Any) -> np.ndarray:
    """Points (robot frame of `me`, (K, 3)) 2 cm in front of the other robot's plate, along it
    at its middle's height."""
    hw, hl = other.config.width_m / 2, other.config.length_m / 2
    along = np.linspace(-0.9 * hw, 0.9 * hw, 9)
    local = np.column_stack([along, np.full(len(along), hl + 0.02)])
    pts = field_to_robot(robot_to_field(local, other.xy, other.heading), me.xy, me.heading)
    return np.column_stack([pts, np.full(len(pts), other.config.height_m / 2)])


def _band(dist: float) -> str:
    lo = 0.0
    for hi in BANDS_M:
        if dist <= hi:
            return f"{lo:g}-{hi:g} m"
        lo = hi
    return f"beyond {lo:g} m"


def _facing_deg(me: Any, other: Any, lens: np.ndarray) -> float:
    """The angle (degrees) between the other robot's plate normal (its forward) and the way to
    the camera's lens: 0 is face on."""
    lens_field = robot_to_field(lens[None, :], me.xy, me.heading)[0]
    fwd = np.array([math.sin(math.radians(other.heading)), math.cos(math.radians(other.heading))])
    to_lens = lens_field - np.asarray(other.xy)
    c = float(fwd @ to_lens) / max(float(np.hypot(*to_lens)), 1e-9)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _facing_band(deg: float) -> str:
    return "face on (<30 deg)" if deg < 30 else "aslant (30-50 deg)" if deg < 50 else "aslant (50+)"


def _project(cam: CameraConfig, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Robot-frame points (N, 3) to pixels (N, 2) and depth along the axis (N,)."""
    pc = cam.mount.robot_to_camera_points(pts)
    return project_points(pc, cam.fx, cam.fy, cam.cx, cam.cy)


def _goal_rim_cut(cam: CameraConfig, xy: np.ndarray, radius: float, height: float) -> str:
    """The image's edges a goal base's rim (at half its height) runs off, "" for none."""
    a = np.linspace(0.0, 2 * math.pi, 16, endpoint=False)
    rim = np.column_stack([xy[0] + radius * np.cos(a), xy[1] + radius * np.sin(a)])
    uv, z = _project(cam, np.column_stack([rim, np.full(len(rim), height / 2)]))
    if np.all(z <= 0):
        return ""
    u, v = uv[z > 0, 0], uv[z > 0, 1]
    cut = {"left": u.min() < 0, "right": u.max() >= cam.width, "top": v.min() < 0,
           "bottom": v.max() >= cam.height}  # fmt: skip
    return ",".join(k for k, c in cut.items() if c)


def _plate_cut(world: World, index: int, other: int, cam: CameraConfig) -> str:
    """The image's edges the other robot's plate (across its front, 8 cm tall at mid-height, as
    sim/world/physics.py draws it) runs off: "side" (left or right), "top", or both; "" for
    none."""
    me, r = world.robots[index], world.robots[other]
    hw, hl, mid = 0.9 * r.config.width_m / 2, r.config.length_m / 2, r.config.height_m / 2
    ends = robot_to_field(np.array([[-hw, hl], [hw, hl]]), r.xy, r.heading)
    local = np.repeat(field_to_robot(ends, me.xy, me.heading), 2, axis=0)
    uv, z = _project(cam, np.column_stack([local, np.tile([mid - 0.04, mid + 0.04], 2)]))
    if np.any(z <= 0):
        return "side"
    cut = {"side": np.any((uv[:, 0] < 0) | (uv[:, 0] >= cam.width)), "top": np.any(uv[:, 1] < 0)}
    return ",".join(k for k, c in cut.items() if c)


# -- matching ----------------------------------------------------------------------------------


@dataclass
class Sighting:
    colour: str
    xy: np.ndarray
    kind: str  # "goal" or "robot"


def match(sightings: list[Sighting], scene: list[Truth]) -> list[tuple[str, int]]:
    """Each sighting's verdict: ("true", truth), ("beyond", truth) or ("false", -1). Nearest
    pairs first, a sighting to an unmatched counted truth of its kind and colour within REACH_M;
    one left over within reach of an uncounted truth of its kind and colour is "beyond"."""
    kind = {t: ("robot" if s.cls.endswith("_robot") else "goal") for t, s in enumerate(scene)}
    pairs = []
    for i, s in enumerate(sightings):
        for t, truth in enumerate(scene):
            if kind[t] == s.kind and truth.colour == s.colour:
                d = float(np.hypot(*(s.xy - truth.xy)))
                if d <= REACH_M:
                    pairs.append((d, i, t))
    verdict: list[tuple[str, int]] = [("false", -1)] * len(sightings)
    taken: set[int] = set()
    for _d, i, t in sorted(pairs):
        if verdict[i][0] == "true" or t in taken or not scene[t].counted:
            continue
        verdict[i] = ("true", t)
        taken.add(t)
    for _d, i, t in sorted(pairs):
        if verdict[i][0] == "false" and not scene[t].counted:
            verdict[i] = ("beyond", t)
    return verdict


def _false_class(s: Sighting, world: World, index: int, classes: list[str]) -> str:
    if s.kind == "robot":
        return f"{s.colour}_robot"
    if s.colour != "yellow":
        return f"{s.colour}_goal"
    me = world.robots[index]
    where = robot_to_field(s.xy[None, :], me.xy, me.heading)[0]
    neutral = [
        (math.hypot(g.x - where[0], g.y - where[1]), c)
        for g, c in zip(world.goals, classes, strict=True)
        if g.spec.alliance is None
    ]
    return min(neutral)[1]


def _miss_cause(truth: Truth, rejected: list[tuple[GoalSighting, BlobShape]], cam: Any) -> str:
    """What a missed goal is put down to: a blob of its colour the shape tests turned down near
    it (placed within REACH_M, or its pixels' middle within a quarter of the image's width of
    the base's), by the test it failed; else no blob of its own (too small, or part of a bigger
    blob of its colour placed elsewhere: a see-saw beside it)."""
    uv, z = _project(cam, np.array([[truth.xy[0], truth.xy[1], 0.04]]))
    for s, shape in rejected:
        if s.colour != truth.colour:
            continue
        if (
            math.isfinite(shape.x)
            and math.hypot(shape.x - truth.xy[0], shape.y - truth.xy[1]) <= REACH_M
        ):
            return f"turned down: {shape.why}"
        if z[0] > 0 and math.hypot(s.u - uv[0, 0], s.v - uv[0, 1]) <= 0.25 * cam.width:
            return f"turned down: {shape.why}"
    return "no blob of its own (too small, or one with something bigger of its colour)"


def _rounded(xy: np.ndarray) -> list[float]:
    return [round(float(c), 2) for c in xy]


# -- the run -----------------------------------------------------------------------------------


@dataclass
class Run:
    scenes: int = 0
    tallies: dict[str, Tally] = field(default_factory=lambda: {c: Tally() for c in CLASSES})
    frames: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)  # for the timing
    render_s: float = 0.0


def run(
    scenes: int, seed: int, misses: Path | None = None, max_miss_images: int = 60
) -> tuple[Run, CameraConfig]:
    world = survey_world()
    index = next(r.index for r in world.robots if r.alliance == "red")  # the 24"
    cam = world.robots[index].config.camera.scaled(*SIZE)
    jcam = JetsonCamera(cam.intrinsics, cam.mount)
    goals, robots = GoalDetector(jcam), RobotDetector(jcam)
    classes = goal_classes(world)
    starts = np.array([[g.x, g.y] for g in world.goals])
    rng = np.random.default_rng(seed)
    out = Run()
    written = 0
    if misses is not None:
        misses.mkdir(parents=True, exist_ok=True)
    log: list[dict[str, Any]] = []
    t0 = time.monotonic()
    for k in range(scenes):
        set_scene(world, rng, index, cam, starts)
        t = time.perf_counter()
        frame = render_camera(world, index, cam)
        out.render_s += time.perf_counter() - t
        bgr = np.ascontiguousarray(frame.rgb[:, :, ::-1])
        if len(out.frames) < SPEED_FRAMES:
            out.frames.append((bgr, frame.depth))
        scene = truths(world, index, cam, classes)
        blobs = goals.blobs(bgr, frame.depth, cam.intrinsics)
        rejected = [(s, shape) for s, shape in blobs if not shape.goal]
        seen = [Sighting(s.colour, np.array([s.x, s.y]), "goal") for s, sh in blobs if sh.goal]
        seen += [Sighting(s.alliance, np.array([s.x, s.y]), "robot") for s in robots.detect(
            bgr, frame.depth, cam.intrinsics)]  # fmt: skip
        verdict = match(seen, scene)
        out.scenes += 1
        events = []
        for truth in scene:
            out.tallies[truth.cls].truths += truth.counted
            out.tallies[truth.cls].hidden_truths += truth.counted and truth.mostly_hidden
        me = world.robots[index]
        for s, (v, t_i) in zip(seen, verdict, strict=True):
            if v == "true":
                tally = out.tallies[scene[t_i].cls]
                tally.true += 1
                tally.hidden_true += scene[t_i].mostly_hidden
                err = float(np.hypot(*(s.xy - scene[t_i].xy)))
                tally.errors_m.append(err)
                for tag in scene[t_i].tags:
                    tally.errors_by_tag.setdefault(tag, []).append(err)
                if err > ERROR_TARGET_M:
                    events.append({"off": scene[t_i].cls, "error_m": round(err, 3),
                                   "at": _rounded(scene[t_i].xy), "placed": _rounded(s.xy),
                                   "tags": scene[t_i].tags})  # fmt: skip
            elif v == "beyond":
                out.tallies[scene[t_i].cls].beyond += 1
            else:
                cls = _false_class(s, world, index, classes)
                where = robot_to_field(s.xy[None, :], me.xy, me.heading)[0]
                what = what_is_there(world, where, s.colour, index)
                out.tallies[cls].false += 1
                out.tallies[cls].false_by_what[what] += 1
                events.append(
                    {"false": cls, "at": [round(float(c), 2) for c in s.xy], "what": what}
                )
        matched = {t_i for v, t_i in verdict if v == "true"}
        for t_i, truth in enumerate(scene):
            if truth.counted and t_i not in matched:
                tally = out.tallies[truth.cls]
                tags = list(truth.tags)
                if truth.cls in GOAL_CLASSES:
                    tags.append(_miss_cause(truth, rejected, cam))
                for tag in tags:
                    tally.missed_by[tag] += 1
                events.append({"missed": truth.cls, "at": _rounded(truth.xy),
                               "tags": tags})  # fmt: skip
        if misses is not None and events and written < max_miss_images:
            name = f"scene{k:05d}.png"
            cv2.imwrite(str(misses / name), _marked(bgr, cam, scene, seen, verdict))
            log.append({"image": name, "events": events})
            written += 1
        if (k + 1) % 100 == 0:
            print(f"  {k + 1}/{scenes} scenes, {time.monotonic() - t0:.0f} s", flush=True)
    if misses is not None:
        (misses / "misses.json").write_text(json.dumps(log, indent=1) + "\n")
    return out, cam


def _marked(
    bgr: np.ndarray,
    cam: CameraConfig,
    scene: list[Truth],
    seen: list[Sighting],
    verdict: list[tuple[str, int]],
) -> np.ndarray:
    """The render, 3x, with the counted truths (green circles: found; red: missed) and the
    sightings (crosses: cyan true, magenta false) marked where their middles project on the
    floor."""
    scale = 3
    img = cv2.resize(bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    found = {t for v, t in verdict if v == "true"}

    def at(xy: np.ndarray) -> tuple[int, int] | None:
        uv, z = _project(cam, np.array([[xy[0], xy[1], 0.0]]))
        if z[0] <= 0:
            return None
        return int(uv[0, 0] * scale), int(uv[0, 1] * scale)

    for t, truth in enumerate(scene):
        p = at(truth.xy)
        if truth.counted and p is not None:
            colour = (0, 200, 0) if t in found else (0, 0, 255)
            cv2.circle(img, p, 10, colour, 2)
            cv2.putText(img, truth.cls, (p[0] + 12, p[1]), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour)
    for s, (v, _t) in zip(seen, verdict, strict=True):
        p = at(s.xy)
        if v != "beyond" and p is not None:
            colour = (255, 255, 0) if v == "true" else (255, 0, 255)
            cv2.drawMarker(img, p, colour, cv2.MARKER_CROSS, 16, 2)
    return img


# -- speed -------------------------------------------------------------------------------------


def speed(frames: list[tuple[np.ndarray, np.ndarray]], cam: CameraConfig) -> dict[str, float]:
    """Frames per second of the goal and robot detectors, and of the ring pipeline with them, on
    the kept renders: one OpenCV thread, the process pinned to one CPU."""
    jcam = JetsonCamera(cam.intrinsics, cam.mount)
    goals, robots = GoalDetector(jcam), RobotDetector(jcam)
    pipe = Pipeline(ClassicalDetector(camera=jcam), jcam, goal_detector=goals)
    stream = [Frame(bgr, depth, cam.intrinsics, 0.0, i) for i, (bgr, depth) in enumerate(frames)]

    def sight() -> None:
        for bgr, depth in frames:
            goals.detect(bgr, depth, cam.intrinsics)
            robots.detect(bgr, depth, cam.intrinsics)

    def whole() -> None:
        for f in stream:
            pipe.process(f)
            robots.detect(f.color, f.depth_m, f.intrinsics)

    threads = cv2.getNumThreads()
    pinned = hasattr(os, "sched_setaffinity")
    cpus = os.sched_getaffinity(0) if pinned else set()
    try:
        cv2.setNumThreads(1)
        if pinned:
            os.sched_setaffinity(0, {min(cpus)})
        n = len(frames)
        return {
            "fps_one_core": per_second(median_ns(sight, repeats=5) / n),
            "fps_one_core_with_rings": per_second(median_ns(whole, repeats=5) / n),
        }
    finally:
        cv2.setNumThreads(threads)
        if pinned:
            os.sched_setaffinity(0, cpus)


# -- the report --------------------------------------------------------------------------------


def table(tallies: dict[str, Tally]) -> str:
    """Per class: the counts, precision, recall, F1, the true sightings' median error, and (the
    diagnostic) F1 with the truths over half hidden left out."""
    rows = [("class", "truths", "true", "false", "missed", "precision", "recall", "F1",
             "median err m", "F1 not hidden")]  # fmt: skip

    def f(v: float | None, digits: int = 3) -> str:
        return "-" if v is None else f"{v:.{digits}f}"

    for cls, t in tallies.items():
        counts = (str(t.truths), str(t.true), str(t.false), str(t.missed))
        rates = (f(t.precision()), f(t.recall()), f(t.f1()), f(t.median_error(), 4))
        rows.append((cls, *counts, *rates, f(t.f1_not_hidden())))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = [
        "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in rows
    ]
    lines.insert(1, "-" * len(lines[0]))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.sight",
        description=(__doc__ or "").splitlines()[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    ap.add_argument("--scenes", type=int, default=1200, help="random scenes rendered")
    ap.add_argument("--seed", type=int, default=0, help="the scenes' random seed")
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where sight.json goes")
    ap.add_argument("--misses", type=Path, help="write marked renders of scenes with misses here")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    args = ap.parse_args(argv)
    if args.scenes < 1:
        ap.error("--scenes must be at least 1")
    t0 = time.perf_counter()
    print(f"bench.sight: {args.scenes} scenes at {SIZE[0]}x{SIZE[1]}, seed {args.seed}")
    got, cam = run(args.scenes, args.seed, args.misses)
    fps = speed(got.frames, cam)
    print()
    print(table(got.tallies))
    print(
        f"\nspeed on {len(got.frames)} renders, one OpenCV thread, pinned to one CPU: goals + "
        f"robots {fps['fps_one_core']:.0f} frames/s; with the classical ring pipeline "
        f"{fps['fps_one_core_with_rings']:.0f} frames/s (rendering: "
        f"{got.render_s / got.scenes * 1e3:.0f} ms a frame, not counted)\n"
    )

    r = Result("sight")
    r.add("scenes", got.scenes)
    for cls, t in got.tallies.items():
        r.add(f"truths_{cls}", t.truths)
        r.add(f"true_{cls}", t.true)
        r.add(f"false_{cls}", t.false)
        r.add(f"missed_{cls}", t.missed)
        for key, value in (
            ("precision", t.precision()),
            ("recall", t.recall()),
            ("f1", t.f1()),
            ("median_error_m", t.median_error()),
        ):
            if value is not None:
                r.add(f"{key}_{cls}", round(value, 4))
    r.add("fps_one_core", round(fps["fps_one_core"], 1))
    r.add("fps_one_core_with_rings", round(fps["fps_one_core_with_rings"], 1))
    r.add("bench_wall_s", round(time.perf_counter() - t0, 1))
    for cls in CLASSES:
        r.target(f"f1_{cls}", F1_TARGET, ">=")
    for cls in CLASSES:
        r.target(f"median_error_m_{cls}", ERROR_TARGET_M, "<=")
    r.target("fps_one_core", FPS_TARGET, ">=")
    path = r.report(args.results)
    details = path.with_name("sight_details.json")
    body = {
        "scenes": got.scenes,
        "seed": args.seed,
        "size": f"{SIZE[0]}x{SIZE[1]}",
        "reach_m": REACH_M,
        "within_m": WITHIN_M,
        "classes": {cls: t.as_dict() for cls, t in got.tallies.items()},
    }
    details.write_text(json.dumps(body, indent=1) + "\n")
    print(f"wrote {details}")
    return 1 if args.strict and not r.all_met else 0


if __name__ == "__main__":
    sys.exit(main())
