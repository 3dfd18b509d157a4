"""--ray and `pete-sim sweep` without a cluster: a missing ray extra and an address where nothing
answers are clear errors, not crashes or hangs; --param parsing; the simulator imports without
ray. The tests that need ray itself skip without it; the missing-extra ones run either way."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from sim.cli import main
from sim.errors import ConfigError, WorkerError
from sim.training.sweep import parse_param, trial_config, with_overrides

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def no_ray(monkeypatch: pytest.MonkeyPatch) -> None:
    """`import ray` fails as it does where the extra is not installed."""
    monkeypatch.setitem(sys.modules, "ray", None)


@pytest.mark.parametrize(
    "argv, command",
    [
        (["train", "--config", "tiny", "--workers", "2", "--ray", "local"], "train"),
        (["eval", "--policy", "planner", "--matches", "2", "--ray", "local"], "eval"),
        (["sweep", "--config", "tiny", "--param", "ppo.learning_rate=1e-3,5e-4"], "sweep"),
    ],
)
def test_a_missing_ray_extra_is_named_with_the_install_command(
    no_ray: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    command: str,
) -> None:
    code = main([*argv, "--run-dir", str(tmp_path / "run")] if command != "eval" else argv)
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"pete-sim {command}: ")
    assert "needs the ray extra: pip install -e .[ray]" in err
    assert not (tmp_path / "run").exists(), "nothing started"


def test_the_simulator_imports_and_lists_its_commands_without_ray() -> None:
    code = (
        "import sys; sys.modules['ray'] = None\n"
        "import sim.cli, sim.training.trainer, sim.training.ray_backend, sim.training.sweep\n"
        "sim.cli.build_parser().parse_args(['sweep', '--config', 'tiny'])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr


def test_an_address_where_no_cluster_answers_fails_fast_and_says_what_to_do(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("ray")
    from sim.errors import ClusterError
    from sim.training.ray_backend import RayBackend

    start = time.perf_counter()
    for address, said in (
        ("127.0.0.1:1", r"no Ray cluster answers at 127\.0\.0\.1:1 .*ray start --head"),
        ("ray://127.0.0.1:1", r"no Ray cluster answers at ray://127\.0\.0\.1:1"),
        ("somewhere", "Ray address 'somewhere': expected host:port"),
    ):
        with pytest.raises(ClusterError, match=said), RayBackend(address):
            pass
    assert time.perf_counter() - start < 30, "no minutes of retries"

    run = tmp_path / "run"
    argv = ["train", "--config", "tiny", "--workers", "1", "--run-dir", str(run)]
    assert main([*argv, "--ray", "127.0.0.1:1"]) == 2
    assert "pete-sim train: no Ray cluster answers at 127.0.0.1:1" in capsys.readouterr().err
    assert main(["eval", "--policy", "planner", "--ray", "127.0.0.1:1"]) == 2
    assert "pete-sim eval: no Ray cluster answers" in capsys.readouterr().err


def test_training_on_ray_needs_rollout_workers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("ray")
    from dataclasses import replace

    from sim.training.config import EvalConfig, load_config
    from sim.training.ray_cli import check_ray_training

    # tiny.toml steps its matches in the training process (workers = 0).
    argv = ["train", "--config", "tiny", "--run-dir", str(tmp_path / "run"), "--ray", "local"]
    assert main(argv) == 2
    assert "[rollout] workers = 0" in capsys.readouterr().err
    tiny = load_config("tiny")
    two = replace(tiny, rollout=replace(tiny.rollout, workers=2))
    check_ray_training(two, 2.0)
    evaluating = replace(two, evaluation=EvalConfig(every_steps=1000))
    with pytest.raises(ConfigError, match=r"has 2 CPU\(s\); 2 rollout actor\(s\) need one each, "):
        check_ray_training(evaluating, 2.0)
    check_ray_training(evaluating, 3.0)
    with pytest.raises(ConfigError, match="--ray spreads the pybullet backend's rollout workers"):
        check_ray_training(replace(two, backend="fast"), 8.0)


def test_a_failing_process_worker_is_a_worker_error_with_its_traceback() -> None:
    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, VecMatches

    rollout = RolloutConfig(workers=1, envs_per_worker=1)
    vec = VecMatches(make_config({}), rollout, seed=1)
    with pytest.raises(WorkerError, match="opponent kind must be one of"):
        vec.set_kinds([("bogus", -1)])
    vec.close()


def test_sweep_params_parse_to_grids_distributions_and_fixed_values() -> None:
    p = parse_param("ppo.learning_rate=1e-3, 5e-4")
    assert p.key == "ppo.learning_rate" and p.values == (1e-3, 5e-4) and not p.fixed
    assert parse_param("ppo.hidden=[32, 32],[64, 64]").values == ([32, 32], [64, 64])
    assert parse_param("evaluation.opponent=planner").values == ("planner",)
    assert parse_param('evaluation.opponent="idle"').fixed
    assert parse_param("ppo.norm_adv=true,false").values == (True, False)
    d = parse_param("ppo.learning_rate=loguniform:1e-4:1e-2")
    assert d.distribution == ("loguniform", 1e-4, 1e-2) and d.corners() == (1e-4, 1e-2)
    assert parse_param("seed=randint:1:4").corners() == (1, 4)
    for bad in ("ppo.learning_rate", "=1", "ppo.gamma=", "ppo.gamma=1,,2", "x=uniform:2:1"):
        with pytest.raises(ConfigError, match="--param"):
            parse_param(bad)


def test_sweep_overrides_are_checked_as_a_config_file_is() -> None:
    data = {"name": "t", "ppo": {"gamma": 0.9}}
    assert with_overrides(data, {"ppo.ent_coef": 0.01, "rollout.workers": 0}) == {
        "name": "t",
        "ppo": {"gamma": 0.9, "ent_coef": 0.01},
        "rollout": {"workers": 0},
    }
    assert data == {"name": "t", "ppo": {"gamma": 0.9}}, "the document itself is left alone"
    assert trial_config(data, {"ppo.ent_coef": 0.01}, "t.toml").ppo.ent_coef == 0.01
    with pytest.raises(ConfigError, match="learning_rat"):
        trial_config(data, {"ppo.learning_rat": 1e-3}, "t.toml")
    with pytest.raises(ConfigError, match="not a table"):
        with_overrides(data, {"name.x": 1})


def test_a_bad_sweep_key_fails_before_tune_starts(tmp_path: Path) -> None:
    pytest.importorskip("ray.tune")
    import ray

    from sim.training.sweep import SweepOptions, run_sweep

    options = SweepOptions("tiny", (parse_param("ppo.learning_rat=1e-3,5e-4"),), tmp_path / "s")
    with pytest.raises(ConfigError, match="learning_rat"):
        run_sweep(options, "127.0.0.1:1")
    assert not ray.is_initialized() and not (tmp_path / "s").exists()
