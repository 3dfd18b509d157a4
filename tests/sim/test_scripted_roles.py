"""The daemon's standard robots (jetson/scripted.py ROBOTS) are the twin's 24" and 15": the
scripted alliance on a robot plans with the sizes, speeds and intake it plays with in the twin."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from jetson.scripted import ROBOTS
from sim.baselines.alliance import robot_role
from sim.config import world_preset
from sim.world.physics import World


def test_the_daemons_robots_are_the_twins() -> None:
    with World(world_preset("tipping_point_2v2")) as w:
        w.reset(np.random.default_rng(0))
        twin = [robot_role(w, i) for i, r in enumerate(w.robots) if r.alliance == "red"]
    assert {r.role for r in twin} == set(ROBOTS)
    for role in twin:
        ours = ROBOTS[role.role]
        for f in dataclasses.fields(role):
            a, b = getattr(role, f.name), getattr(ours, f.name)
            if isinstance(a, tuple | float):
                assert a == pytest.approx(b, abs=1e-4), f.name
            else:
                assert a == b, f.name
