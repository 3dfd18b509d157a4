"""Rollouts, evaluation, training and sweeps on a Ray cluster: Ray's local multi-node test cluster,
two nodes on this machine, started once for the module. Skipped without the ray extra."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ray = pytest.importorskip("ray")
pytest.importorskip("ray.tune")

from ray.cluster_utils import Cluster  # noqa: E402

from sim.cli import main  # noqa: E402
from sim.errors import WorkerError  # noqa: E402
from sim.evaluate import EVAL_WORLD, evaluate, load_player  # noqa: E402
from sim.match import make_config  # noqa: E402
from sim.training.config import CONFIG_DIR  # noqa: E402
from sim.training.ray_backend import RayBackend  # noqa: E402
from sim.training.rollout import RolloutConfig, StepResult, VecMatches  # noqa: E402
from sim.training.sweep import SweepOptions, parse_param, run_sweep  # noqa: E402

CPUS_PER_NODE = 2  # two rollout actors, one on each node, leave a CPU each for evaluation tasks


@pytest.fixture(scope="module")
def cluster() -> Iterator[Cluster]:
    c = Cluster(
        initialize_head=True,
        head_node_args={"num_cpus": CPUS_PER_NODE, "include_dashboard": False},
    )
    c.add_node(num_cpus=CPUS_PER_NODE)
    c.wait_for_nodes()
    yield c
    c.shutdown()


def _play(vec: VecMatches, steps: int) -> list[StepResult]:
    """reset, then `steps` steps of seeded random actions for the learner and policy opponents."""
    vec.set_kinds([("planner", -1), ("policy", 7), ("scripted", -1), ("none", -1)])
    rng = np.random.default_rng(0)
    out = [vec.reset()]
    for _ in range(steps):
        out.append(vec.step(rng.uniform(-1, 1, (4, 2)), rng.uniform(-1, 1, (4, 2))))
    return out


def _assert_same(a: StepResult, b: StepResult) -> None:
    for f in dataclasses.fields(StepResult):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y, err_msg=f.name)
        else:
            assert x == y, f.name


def test_vec_matches_over_ray_actors_give_the_process_workers_results(cluster: Cluster) -> None:
    env = make_config({"max_steps": 10})  # matches end and reset within the run
    rollout = RolloutConfig(workers=2, envs_per_worker=2)
    with VecMatches(env, rollout, seed=3, teacher="planner") as vec:
        here = _play(vec, 12)
    with (
        RayBackend(cluster.address) as backend,
        VecMatches(env, rollout, seed=3, teacher="planner", launcher=backend.launch) as vec,
    ):
        there = _play(vec, 12)
        assert len(set(backend.nodes)) == 2, "Ray spread the two actors over both nodes"
        # An actor's failure comes back as the process workers' does, with its traceback.
        with pytest.raises(WorkerError, match="opponent kind must be one of"):
            vec.set_kinds([("bogus", -1)] * 4)
    assert sum(len(r.episodes) for r in here) == 4, "every slot finished a match"
    for a, b in zip(here, there, strict=True):
        _assert_same(a, b)


def test_evaluation_as_ray_tasks_gives_the_same_matches(cluster: Cluster) -> None:
    short = {"max_steps": 90, "world": EVAL_WORLD}
    args: dict[str, Any] = {"matches": 4, "seed": 11, "base_env": short}
    here = evaluate(load_player("planner"), load_player("scripted"), **args)
    seen: list[int] = []
    with RayBackend(cluster.address) as backend:
        there = evaluate(
            load_player("planner"),
            load_player("scripted"),
            **args,
            runner=backend.play,
            progress=lambda done, total: seen.append(done),
        )
    assert there.matches == here.matches
    assert seen[-1] == 4


def test_training_on_the_cluster_spreads_its_actors_and_evaluates_there(
    cluster: Cluster, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny_eval.toml"
    config.write_text(
        (CONFIG_DIR / "tiny.toml").read_text()
        + '\n[evaluation]\nevery_steps = 1024\nmatches = 2\nopponent = "idle"\n'
    )
    run = tmp_path / "run"
    argv = ["train", "--config", str(config), "--run-dir", str(run), "--no-progress"]
    # tiny: 8 matches a worker, 64 steps each: one iteration of 1024 steps on two workers.
    code = main([*argv, "--steps", "1024", "--workers", "2", "--ray", cluster.address])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "1024 steps" in out
    assert "2 rollout actors on 2 node(s)" in out, out
    history = [json.loads(line) for line in (run / "history.jsonl").read_text().splitlines()]
    assert [h["step"] for h in history] == [1024]
    assert all("eval/win_rate" in h for h in history), "evaluated as Ray tasks"
    assert (run / "policy.onnx").is_file()


def test_a_sweep_runs_its_trials_with_tune_on_the_cluster(cluster: Cluster, tmp_path: Path) -> None:
    options = SweepOptions(
        config="tiny",
        params=(
            parse_param("ppo.learning_rate=1e-3,5e-4"),
            parse_param("evaluation.matches=2"),
            parse_param('evaluation.opponent="idle"'),
        ),
        run_dir=tmp_path / "sweep",
        steps=512,
        verbose=0,
    )
    result = run_sweep(options, cluster.address, log=lambda line: None)
    assert [r.status for r in result.rows] == ["done", "done"], result.table()
    assert sorted(r.params["ppo.learning_rate"] for r in result.rows) == [5e-4, 1e-3]
    assert all(r.metric is not None and r.step == 512 for r in result.rows)
    assert result.best is not None
    for r in result.rows:
        assert (Path(r.run_dir) / "policy.onnx").is_file(), r.run_dir
    summary = json.loads(result.summary.read_text())
    assert summary["metric"] == "eval/quality" and len(summary["trials"]) == 2
    assert summary["best"] == result.best.trial
    assert "ppo.learning_rate" in result.table()
