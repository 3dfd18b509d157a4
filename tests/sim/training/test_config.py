"""Training configs: the shipped TOML files, the report's hyperparameters, clear errors."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from sim.errors import ConfigError
from sim.training.config import CONFIG_DIR, load_config, parse_config


def test_shipped_configs_load() -> None:
    names = sorted(p.stem for p in CONFIG_DIR.glob("*.toml"))
    assert {"default", "reference", "tiny"} <= set(names)
    for name in names:
        cfg = load_config(name)
        assert cfg.name == name
        cfg.env_config()


def test_reference_config_is_the_reports() -> None:
    cfg = load_config("reference")
    p = cfg.ppo
    assert cfg.rollout.buffer_size == 10500
    assert p.minibatch_size == 1050
    assert (p.learning_rate, p.anneal_lr, p.ent_coef, p.clip_coef) == (3e-4, True, 0.005, 0.2)
    assert (p.gae_lambda, p.n_epochs, p.hidden, p.gamma) == (0.95, 3, (128, 128), 0.99)
    assert (p.norm_obs, p.activation) == (False, "silu")
    assert cfg.total_steps == 1_000_000
    sp = cfg.selfplay
    assert (sp.window, sp.play_against_latest_model_ratio) == (10, 0.5)
    assert (sp.save_steps, sp.swap_steps) == (10_000, 10_000)
    reward = cfg.env_config().reward
    assert (reward.ring, reward.ring_cap, reward.pin) == (5.0, 10, -5.0)
    assert (reward.goal_end, reward.opponent_side_end) == (12.0, -17.5)


def test_none_in_toml_and_unknown_keys(tmp_path: Path) -> None:
    f = tmp_path / "x.toml"
    f.write_text('name = "x"\n[env.reward]\nring_cap = "none"\n')
    assert load_config(f).env_config().reward.ring_cap is None
    f.write_text('name = "x"\n[ppo]\nlearnin_rate = 1e-3\n')
    with pytest.raises(ConfigError, match="learnin_rate"):
        load_config(f)
    f.write_text('name = "x"\n[env.world]\nfidelty = "high"\n')
    with pytest.raises(ConfigError, match="fidelty"):
        load_config(f)
    f.write_text('name = "x"\n[opponents]\nwizard = 1.0\n')
    with pytest.raises(ConfigError, match="wizard"):
        load_config(f)
    f.write_text("name = [")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(f)
    with pytest.raises(ConfigError, match="no config file"):
        load_config(tmp_path / "missing.toml")


def test_opponent_shares_become_slots() -> None:
    cfg = parse_config(
        {
            "rollout": {"workers": 2, "envs_per_worker": 8},
            "opponents": {"pool": 0.75, "planner": 0.25},
        }
    )
    slots = cfg.opponent_slots()
    assert Counter(slots) == {"pool": 12, "planner": 4}
    # Each worker gets the same mix.
    assert Counter(slots[:8]) == Counter(slots[8:]) == {"pool": 6, "planner": 2}


def test_phases_apply_in_order_and_may_not_resize_buffers() -> None:
    base = {
        "rollout": {"workers": 0, "envs_per_worker": 4},
        "opponents": {"pool": 1.0},
        "phases": [
            {"from_step": 100, "rollout": {"short_share": 0.5}, "env": {"reward": {"score": 0.2}}},
            {"from_step": 200, "opponents": {"idle": 1.0}, "env": {"reward": {"ring": 2.0}}},
        ],
    }
    cfg = parse_config(base)
    assert [cfg.phase_index(s) for s in (0, 99, 100, 199, 200)] == [0, 0, 1, 1, 2]
    late = cfg.at_step(250)
    assert late.rollout.short_share == 0.5, "phases accumulate"
    assert late.env_config().reward.score == 0.2 and late.env_config().reward.ring == 2.0
    assert late.opponents == {"idle": 1.0} and late.phases == ()
    assert cfg.at_step(0).env_config().reward.score == 0.0
    drive = load_config("drive")
    # The drive policy's curriculum: goal starts, then none with the parking shaping, then a
    # fine-tune.
    shares = [drive.at_step(s).env_config().goal_start_share for s in (0, 800_000, 1_400_000)]
    assert shares == [0.3, 0.1, 0.0]
    assert drive.at_step(0).env_config().reward.park == 0.0
    assert drive.at_step(1_400_000).env_config().reward.park == 2.0
    assert drive.at_step(2_000_000).env_config().goal_start_share == 0.15
    assert drive.at_step(2_000_000).env_config().world.robots["15in"].ring_capacity == 10
    # The shipped config scores skills, has the planner as a teacher and plays both games.
    default = load_config("default")
    env = default.env_config()
    skills = env.skills
    assert skills is not None and skills.option_names()[:2] == ["route", "ring0"]
    assert env.action_size == len(default.ppo.init_action_bias) == 8
    assert env.observation is not None and env.observation.intake_flag
    assert env.uncapped_share > 0 and env.match_reward(True).clamp == 0.0 < env.reward.clamp
    assert default.imitation.teacher == "planner" and default.imitation.coef_at(0) > 0
    with pytest.raises(ConfigError, match="may set only"):
        parse_config({**base, "phases": [{"from_step": 10, "rollout": {"workers": 3}}]})
    with pytest.raises(ConfigError, match="from_step"):
        parse_config({**base, "phases": [{"from_step": 10}, {"from_step": 5}]})
