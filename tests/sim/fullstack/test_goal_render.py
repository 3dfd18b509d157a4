"""The full stack's camera frames show the mobile goals as the daemon's goal detector finds them:
in `pete-sim match --world tipping_point_2v2` the red 24" runs the scripted alliance, so its
camera pipeline has the goal detector (`[camera] goals` defaults on for that player), and the
frames the twin renders for it (sim/camera.py: the field file's goal colours, yellow neutral, red
and blue alliance goals) give the goals the twin's geometric sighting reports (sim/goal_sight.py),
at their bases' middles (sim/goal_survey.py measures it over many poses)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.perception.camera import CameraConfig as JetsonCamera
from jetson.perception.frame import Frame
from jetson.perception.pipeline import make_pipeline
from jetson.settings import Settings
from sim.camera import render_camera
from sim.evaluate import eval_env
from sim.goal_sight import visible_goals
from sim.match import MatchCore
from sim.world.physics import World
from tests.jetson.perception.test_goal_pipeline import assert_goal_at

SIZE = (240, 180)  # the full stack's default camera size (MatchOptions)


@pytest.fixture(scope="module")
def world() -> World:
    env = eval_env("capped", "training", world="tipping_point_2v2")
    core = MatchCore(env, replace(env.world, control_hz=50.0))
    core.reset(np.random.default_rng(0))
    return core.world


def red_24(world: World) -> int:
    return next(i for i, r in enumerate(world.robots) if r.alliance == "red")


def test_the_whole_games_daemon_finds_goals() -> None:
    # DaemonHost's settings for the whole game (sim/fullstack/daemon.py): the scripted alliance.
    assert Settings().with_overrides(decision={"player": "alliance"}).detects_goals()


@pytest.mark.parametrize("goal", ["neutral_south", "neutral_tall", "red_north", "blue_south"])
def test_a_rendered_goal_is_found_where_the_twin_sees_it(
    world: World, goal: str, tmp_path: Path
) -> None:
    ia = red_24(world)
    k = next(i for i, g in enumerate(world.goals) if g.spec.name == goal)
    g = world.goals[k]
    cam = world.robots[ia].config.camera.scaled(*SIZE)
    config = tmp_path / "camera.json"
    JetsonCamera(cam.intrinsics, cam.mount).save(config)
    settings = Settings().with_overrides(
        camera={"detector": "classical", "config": str(config)}, decision={"player": "alliance"}
    )
    _, pipeline = make_pipeline(replace(settings.camera, goals=settings.detects_goals()))
    # The robot 1.1 m from the goal on the field's side of it, facing it, 10 degrees off.
    toward_middle = math.atan2(-g.x, -g.y) if (g.x, g.y) != (0.0, 0.0) else math.pi
    x = g.x + 1.1 * math.sin(toward_middle)
    y = g.y + 1.1 * math.cos(toward_middle)
    world.place_robot(ia, x, y, (math.degrees(toward_middle) + 180.0 + 10.0) % 360.0)
    f = render_camera(world, ia, cam)
    truth = visible_goals(world, ia)
    colour = "yellow" if g.spec.alliance is None else g.spec.alliance
    rows = truth[truth[:, 2] == GOAL_COLOUR_CODES[colour]]
    nearest = rows[np.argmin(np.hypot(rows[:, 0], rows[:, 1]))]
    frame = Frame(np.ascontiguousarray(f.rgb[:, :, ::-1]), f.depth, cam.intrinsics, 0.0, 1)
    found = pipeline.process(frame).goals_robot
    # The goal's sighting (a piece of a platform of the goal's colour at the image's edge can
    # still pass the shape tests: jetson/perception/README.md).
    found = found[found[:, 2] == GOAL_COLOUR_CODES[colour]]
    assert len(found), truth
    best = found[[np.argmin(np.hypot(*(found[:, :2] - nearest[:2]).T))]]
    assert_goal_at(best, colour, *nearest[:2])
