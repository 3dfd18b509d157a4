"""The shipped learned alliance (jetson/models/alliance/) is what sim/configs/alliance.toml
trains: the same observation (fingerprint), the partner block, the seen opponents and the role
input, the same skills; exported with the controller sharing the platform and splitting the
field with the partner (`pete-sim export --skill`)."""

from __future__ import annotations

import json

from jetson.autonomy.policy import OnnxPolicy
from jetson.models import ALLIANCE_POLICY
from sim.fast.matches import FastMatches
from sim.training.config import load_config
from sim.training.rollout import RolloutConfig


def test_the_shipped_alliance_policy_is_what_alliance_toml_trains() -> None:
    policy = OnnxPolicy(ALLIANCE_POLICY)
    env = load_config("alliance").env_config()
    spec = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=2), seed=0).spec
    assert policy.spec.fingerprint() == spec.fingerprint()
    assert policy.spec.partner and policy.spec.seen_opponents and policy.spec.role_flag
    assert policy.skills is not None and env.skills is not None
    assert policy.skills.option_names() == env.skills.option_names()
    assert policy.skills.share_platform and policy.skills.split_with_partner
    assert not env.skills.share_platform and not env.skills.split_with_partner  # set at export
    meta = json.loads(ALLIANCE_POLICY.with_suffix(".json").read_text())
    assert meta["training"]["skills_set"] == {
        "share_platform": True, "split_with_partner": True, "keep_clear_s": 45,
        "keep_clear_m": 0.55, "climb_at_s": 35, "platform_past_m": [0.045, 0.16],
    }  # fmt: skip
    # The endgame as exported: clear of the other platform, the climb with the goals balanced.
    s = policy.skills
    assert (s.keep_clear_s, s.climb_at_s, s.platform_past_m) == (45, 35, (0.045, 0.16))
    assert s.release_dragged_s == 0.0  # letting go in tugs cost goals: the endgame note
