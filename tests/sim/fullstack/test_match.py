"""`pete-sim match`: short full-stack and sim-stack matches with a test policy.

The policy here always answers "forward at half speed, no turn" (a one-layer ONNX net with zero
weights), so what the robot does is known: if it moves forward along its heading at the commanded
speed, the whole chain worked (observation, policy, Command, pty, Brain core, motors, World).
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest

from sim import cli
from sim.errors import MatchError
from sim.fullstack.brain_host import DEFAULT_BINARY
from sim.fullstack.options import MatchOptions
from sim.fullstack.runner import run_match

pytestmark = pytest.mark.skipif(
    not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build` first"
)

FORWARD = 0.5  # policy output: x 0.904 m/s = 0.452 m/s


def constant_policy(folder: Path, linear: float = FORWARD, angular: float = 0.0) -> Path:
    """A policy.onnx whose answer never changes: tanh(0 * obs + atanh(action))."""
    import onnx
    from onnx import numpy_helper

    from jetson.testing import write_mlp_policy

    path = write_mlp_policy(folder, hidden=())
    model = onnx.load(path)
    for init in model.graph.initializer:
        arr = numpy_helper.to_array(init)
        if init.name == "w0":
            new = np.zeros_like(arr)
        elif init.name == "b0":
            new = np.arctanh(np.array([linear, angular], dtype=np.float32))
        else:
            continue
        init.CopyFrom(numpy_helper.from_array(new.astype(np.float32), init.name))
    path.write_bytes(model.SerializeToString())
    meta_path = path.with_suffix(".json")
    meta = json.loads(meta_path.read_text())
    meta["onnx_sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    meta_path.write_text(json.dumps(meta))
    return path


@pytest.fixture(scope="module")
def policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return constant_policy(tmp_path_factory.mktemp("policy"))


def options(policy: Path, out: Path, **kw: object) -> MatchOptions:
    base = {"seconds": 3.0, "gif": False, "plots": False, "opponent": "none"}
    base.update(kw)
    return MatchOptions(policy=policy, out=out, **base)  # type: ignore[arg-type]


def start_pose(seed: int) -> tuple[float, float, float]:
    from sim.evaluate import eval_env
    from sim.world.physics import World

    env = eval_env("capped", "training")
    with World(env.world) as w:
        w.reset(np.random.default_rng(seed))
        r = w.robots[0]
        return r.x, r.y, r.heading


def test_full_stack_drives_the_robot_as_the_policy_says(policy: Path, tmp_path: Path) -> None:
    result = run_match(options(policy, tmp_path / "run", gif=True, gif_every_s=1.0))
    assert result.stack == "full" and result.mode == "lockstep"
    assert result.sim_s == pytest.approx(3.0)
    timeline = (tmp_path / "run" / "timeline.csv").read_text().splitlines()
    header = timeline[0].split(",")
    last = dict(zip(header, timeline[-1].split(","), strict=True))
    # The Brain drove what the policy asked: 0.452 m/s straight, through its slew limit.
    assert last["source"] == "jetson" and last["link"] == "connected"
    assert float(last["v_cmd"]) == pytest.approx(FORWARD * 0.904, abs=1e-3)
    assert float(last["w_cmd"]) == pytest.approx(0.0, abs=1e-6)
    assert float(last["v_actual"]) == pytest.approx(FORWARD * 0.904, abs=0.02)
    # ...and every byte between the two sides arrived: no loss, no refusal.
    for way in ("up", "down"):
        m = result.messages[way]
        assert m["sent"] == m["received"] > 100
        assert m["lost"] == m["rejected"] == m["altered"] == 0
    assert result.messages["up"]["sent_by_type"]["State"] >= 150, "50 Hz for 4 s (with pre-roll)"
    assert result.latency["n"] >= 150 and result.latency["p99_ms"] > 0
    assert result.brain["command_age"]["p50_ms"] == 10.0, "answered within one Brain loop step"
    assert result.brain["driven_s"] >= 2.9
    assert result.daemon["counters"]["connects"] == 1
    p = result.perception
    assert p["frames"] >= 10 and p["frames_failed"] == 0
    assert p["f1"] is not None and p["f1"] > 0.6, p
    folder = tmp_path / "run"
    for name in ("summary.txt", "summary.json", "replay.gif", "replay.png", "daemon.jsonl"):
        assert (folder / name).is_file(), name
    assert "rings collected" in (folder / "summary.txt").read_text()
    assert json.loads((folder / "summary.json").read_text())["passed"] is True


def test_lockstep_is_deterministic(policy: Path, tmp_path: Path) -> None:
    from jetson.testing import write_mlp_policy

    wiggly = write_mlp_policy(tmp_path / "wiggly", seed=11)
    runs = [
        run_match(options(wiggly, tmp_path / f"run{k}", seconds=2.0, opponent="planner"))
        for k in range(2)
    ]
    a, b = ((tmp_path / f"run{k}" / "timeline.csv").read_text() for k in range(2))
    assert a == b
    assert runs[0].messages == runs[1].messages
    assert runs[0].perception == runs[1].perception


def test_robot_moves_along_its_heading(policy: Path, tmp_path: Path) -> None:
    x0, y0, h0 = start_pose(4)
    run_match(options(policy, tmp_path / "run", seed=4, seconds=2.0, camera=False))
    rows = (tmp_path / "run" / "timeline.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert len(rows) == 21, "a sample every 100 ms"
    end = dict(zip(header, rows[-1].split(","), strict=True))
    dx, dy = float(end["x"]) - x0, float(end["y"]) - y0
    along = dx * math.sin(math.radians(h0)) + dy * math.cos(math.radians(h0))
    across = -dx * math.cos(math.radians(h0)) + dy * math.sin(math.radians(h0))
    # 0.452 m/s for 2 s, less the ramp up through the Brain's and the robot's slew limits.
    assert along == pytest.approx(0.452 * 2 - 0.05, abs=0.06)
    assert abs(across) < 0.01
    assert float(end["heading"]) == pytest.approx(h0, abs=0.5)


def test_sim_stack_runs_the_same_policy(policy: Path, tmp_path: Path) -> None:
    result = run_match(options(policy, tmp_path / "sim", stack="sim", gif=True))
    assert result.stack == "sim" and result.messages is None
    assert result.sim_s == pytest.approx(3.0, abs=0.1)
    assert result.latency["n"] == 36, "12 Hz for 3 s"
    rows = (tmp_path / "sim" / "timeline.csv").read_text().splitlines()
    end = dict(zip(rows[0].split(","), rows[-1].split(","), strict=True))
    assert float(end["v_cmd"]) == pytest.approx(0.452, abs=1e-3)
    assert (tmp_path / "sim" / "replay.gif").is_file()


def test_bad_options_are_named(policy: Path, tmp_path: Path) -> None:
    with pytest.raises(MatchError, match="stack"):
        MatchOptions(stack="half")
    with pytest.raises(MatchError, match="camera_hz"):
        MatchOptions(camera_hz=7.0)
    with pytest.raises(MatchError, match="full stack"):
        MatchOptions(stack="sim", fault="link-cut")
    with pytest.raises(MatchError, match="no policy"):
        run_match(options(tmp_path / "missing.onnx", tmp_path / "x"))
    with pytest.raises(MatchError, match="unknown fault"):
        run_match(options(policy, tmp_path / "x", fault="meteor"))
    with pytest.raises(MatchError, match="within the match"):
        run_match(options(policy, tmp_path / "x", fault="link-cut", fault_at_s=9.0))


def test_cli_prints_the_summary(policy: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "cli"
    args = ["match", "--policy", str(policy), "--seconds", "1", "--out", str(out)]
    code = cli.main([*args, "--no-gif", "--no-plots", "--opponent", "none", "--quiet"])
    text = capsys.readouterr().out
    assert code == 0
    assert "messages Jetson -> Brain" in text and f"run folder: {out}" in text
    code = cli.main(["match", "--policy", str(tmp_path / "nope.onnx"), "--out", str(out)])
    assert code == 2
    assert "no policy" in capsys.readouterr().err


def test_realtime_runs_on_the_wall_clock(policy: Path, tmp_path: Path) -> None:
    result = run_match(options(policy, tmp_path / "rt", seconds=2.0, realtime=True))
    assert result.mode == "realtime"
    assert result.wall_s >= 3.0, "a 1 s pre-roll and a 2 s match take 3 s of wall clock"
    up = result.messages["up"]
    # brain_host ran its own 10 ms loop: about 50 States a second, all delivered.
    assert 120 <= up["sent_by_type"]["State"] <= 200
    assert up["lost"] == 0 and result.messages["down"]["rejected"] == 0
    assert result.latency["n"] >= 100
    rows = (tmp_path / "rt" / "timeline.csv").read_text().splitlines()
    end = dict(zip(rows[0].split(","), rows[-1].split(","), strict=True))
    assert end["source"] == "jetson"
    assert float(end["v_actual"]) == pytest.approx(0.452, abs=0.03)


def test_bench_compares_the_stacks(policy: Path, tmp_path: Path, capsys) -> None:
    from bench import match as bench_match

    args = ["--seeds", "1", "--seconds", "1", "--policy", str(policy), "--opponent", "none"]
    code = bench_match.main([*args, "--out", str(tmp_path / "runs"), "--results", str(tmp_path)])
    assert code == 0
    data = json.loads((tmp_path / "match.json").read_text())
    m = data["metrics"]
    assert m["matches_per_stack"] == 1 and m["match_seconds"] == 1
    # The constant policy drives straight on both stacks: same rings (likely none in 1 s).
    assert m["rings_full_mean"] == m["rings_sim_mean"]
    assert m["messages_lost"] == 0 and m["loop_latency_p99_ms"] > 0
    assert set(data["targets"]) == {
        "rings_full_over_sim", "lockstep_wall_s_median", "loop_latency_p99_ms",
    }  # fmt: skip
    assert "seed 0 full" in capsys.readouterr().out


def test_a_camera_thread_that_gives_up_in_the_preroll_is_taken_back(
    policy: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The frame stream's read timeout is wall time; on a loaded machine the preroll (no frames)
    can outlast it, and the daemon's camera thread gives up and connects again. The match takes
    the new connection at its next frame, and the frames flow (none did before)."""
    from jetson.perception.sources import stream

    real = stream.StreamSource.__init__
    opened: list[str] = []

    def impatient(self: object, address: str, connect_timeout_s: float = 5.0, *_: object) -> None:
        # The first connection gives up at once in the preroll; the one it makes again keeps the
        # default read timeout (a short one throughout would starve a slow machine mid-match too).
        read_timeout_s = 0.05 if not opened else 5.0
        opened.append(address)
        real(self, address, connect_timeout_s, read_timeout_s)  # type: ignore[arg-type]

    monkeypatch.setattr(stream.StreamSource, "__init__", impatient)
    result = run_match(options(policy, tmp_path / "run"))
    log = [json.loads(x) for x in (tmp_path / "run" / "daemon.jsonl").read_text().splitlines()]
    events = [e["event"] for e in log]
    assert "camera_error" in events and events.count("camera_open") >= 2  # it gave up, came back
    assert result.perception is not None and result.perception["frames"] > 0
