"""The twin fills observation spec 6's partner block as the robot's VEXlink reports would: each
robot of a 2v2 sees its partner where it is, with its clamp and rings, and the target the
partner's skill driver claimed."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.geometry import field_to_robot
from sim.match import MatchCore, make_config, partner_of


def test_partners_are_found_by_alliance() -> None:
    assert partner_of(["red", "red", "blue", "blue"], 0) == 1
    assert partner_of(["red", "red", "blue", "blue"], 3) == 2
    assert partner_of(["red", "blue"], 0) is None


def test_each_robot_sees_its_partner_and_the_target_its_skill_driver_claimed() -> None:
    cfg = make_config(
        world={"red": ["24in", "15in"], "blue": ["24in", "15in"], "interaction_s": 5.0},
        observation={
            "version": 6,
            "partner": True,
            "n_stack": 0,
            "match_length_s": 5.0,
            "goal_memory": True,
        },
        skills={"ring_options": 2, "goal_options": 1, "platform": True},
        obs_noise=False,
        gps_noise=False,
    )
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(1))
    spec = core.spec
    lo = spec.partner_offset
    n = core.config.skills.n_options
    claimed = 0
    for step in range(30):
        # Robot k picks option k % n: the rings, the goal, the platform.
        actions = [np.where(np.arange(n) == (k + step // 10) % n, 1.0, -1.0) for k in range(4)]
        commands = [core.command(k, a) for k, a in enumerate(actions)]
        before = list(core.claims)
        results, _, _ = core.step(commands)
        w = core.world
        for i, res in enumerate(results):
            k = partner_of([r.alliance for r in w.robots], i)
            r, p = w.robots[i], w.robots[k]
            block = res.observation[lo : lo + 8]
            near = field_to_robot(np.array([p.xy]), r.xy, r.heading)[0] / spec.length_unit_m
            assert block[:2] == pytest.approx(near, abs=1e-5) and block[2] == 1.0
            assert block[3] == float(p.carried_goal is not None)
            assert block[4] == pytest.approx(p.held / spec.ring_capacity_norm)
            claim = before[k]
            assert block[7] == float(claim is not None)
            if claim is not None:
                claimed += 1
                at = field_to_robot(np.array([claim]), r.xy, r.heading)[0] / spec.length_unit_m
                assert block[5:7] == pytest.approx(at, abs=1e-5)
    assert claimed > 30
    # The platform option claims the alliance's platform (red's: -y in the field frame).
    plat = core.world.field.platform("red").center
    platform_robot = next(k for k in range(2) if (k + 2) % n == n - 1)
    assert core.claims[platform_robot] == pytest.approx(tuple(plat), abs=1e-6)


def test_a_stop_claims_nothing_and_the_scripted_alliance_claims_as_on_the_robot() -> None:
    """A non-finite action is a stop and drops the robot's claim (the fast backend and the
    Jetson's decision claim nothing then); the scripted alliance (AlliancePlayer) claims in the
    twin what it claims in a partner report (AllianceStrategy.field_claim)."""
    from sim.baselines.alliance import AlliancePlayer

    cfg = make_config(
        world={
            "red": ["24in", "15in"], "blue": ["24in", "15in"], "game": "tipping_point",
            "isolation_s": 15.0,
        },
        observation={"version": 6, "partner": True, "n_stack": 0, "goal_memory": True,
                     "match_length_s": 120.0},
        skills={"ring_options": 2, "goal_options": 1, "platform": True},
        obs_noise=False, gps_noise=False,
    )  # fmt: skip
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(2))
    n = core.config.skills.n_options
    core.command(0, np.where(np.arange(n) == n - 1, 1.0, -1.0))  # the platform
    assert core.claims[0] is not None
    core.command(0, np.full(n, np.nan))
    assert core.claims[0] is None
    player = AlliancePlayer()
    player.reset(core, 1)
    claims = []
    for _ in range(60):
        commands = [core.command(0, np.full(n, np.nan)), player.act(core, 1)]
        commands += [core.command(k, np.full(n, np.nan)) for k in (2, 3)]
        core.step(commands)
        got = player.strategy.field_claim("red")
        assert core.claims[1] == (None if got is None else got[1])
        claims.append(core.claims[1])
    assert any(c is not None for c in claims)
