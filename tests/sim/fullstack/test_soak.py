"""bench.soak: the fault schedule it plans, the log rate it measures, and a tiny soak end to end."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from bench import soak
from sim.fullstack.brain_host import DEFAULT_BINARY
from sim.fullstack.faults import FAULTS, Schedule


def test_the_plan_spreads_every_kind_evenly_without_overlap() -> None:
    plan = soak.plan_faults(210, 10, 105.0, seed=0)
    assert len(plan) == 21 and all(len(s) == 10 for s in plan)
    kinds = Counter(kind for schedule in plan for kind, _ in schedule)
    assert kinds == dict.fromkeys(soak.KINDS, 30)
    for schedule in plan:
        assert all(soak.FIRST_FAULT_S <= at <= 105.0 - soak.END_MARGIN_S for _, at in schedule)
        # What the match itself would refuse: faults overlapping another's span.
        parts = [FAULTS[k](at, 105.0, duration_s=FAULTS[k].window_s) for k, at in schedule]
        Schedule(parts, 105.0)
    assert soak.plan_faults(210, 10, 105.0, seed=0) == plan, "seeded"
    assert soak.plan_faults(210, 10, 105.0, seed=1) != plan


def test_the_plan_refuses_faults_that_do_not_fit() -> None:
    with pytest.raises(SystemExit, match="do not fit"):
        soak.plan_faults(10, 10, 30.0)
    assert soak.most_per_match(30.0) == 4


def test_log_rate_counts_the_busiest_minute() -> None:
    quiet = [{"t": float(t)} for t in range(120)]  # a line a second
    assert soak.log_rate_max(quiet) == pytest.approx(61.0)
    burst = quiet + [{"t": 50.5}] * 300
    assert soak.log_rate_max(burst) == pytest.approx(361.0)
    short = [{"t": t / 10} for t in range(100)]  # 10 s of ten lines a second
    assert soak.log_rate_max(short) == pytest.approx(600.0, rel=0.02)
    assert soak.log_rate_max([]) == 0.0


@pytest.mark.skipif(not DEFAULT_BINARY.exists(), reason="brain_host is not built: `make build`")
def test_a_tiny_soak(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from jetson.testing import write_mlp_policy

    policy = write_mlp_policy(tmp_path / "policy", seed=3)
    args = ["--faults", "2", "--seeds", "1", "--seconds", "12", "--policy", str(policy)]
    code = soak.main([*args, "--out", str(tmp_path / "runs"), "--results", str(tmp_path)])
    assert code == 0
    data = json.loads((tmp_path / "soak.json").read_text())
    m = data["metrics"]
    # 12 s matches hold one fault each (the longest spans 6 s): two fault matches.
    assert m["faults_injected"] == 2 and m["fault_matches"] == 2 and m["ring_seeds"] == 1
    assert m["matches_failed_to_run"] == 0
    assert m["motor_steps_invalid_command"] == 0 and m["motor_steps_jetson"] > 1000
    assert set(data["targets"]) == {
        "motor_steps_invalid_command", "stop_after_command_loss_ms_max", "sigterm_exit_s_max",
        "sigterm_exits_without_stop", "reconnect_after_cable_ms_max", "log_lines_per_min_max",
        "rings_lost_to_cable_pull_mean",
    }  # fmt: skip
    details = json.loads((tmp_path / "soak_details.json").read_text())
    assert {f["kind"] for f in details["faults"]} >= {"link-cut"}, "the ring match's cut"
    assert len(details["matches"]) == 4 and details["rings"][0]["seed"] == 0
    out = capsys.readouterr().out
    assert "faults seed 1000" in out and "free   seed    0" in out
