"""Checkpoints hold tensors and plain data and load with weights_only=True: a crafted pickle is
refused before it runs anything; resume, export and a .pt player keep working."""

from __future__ import annotations

import os
from collections import OrderedDict
from dataclasses import replace
from enum import IntEnum
from pathlib import Path

import numpy as np
import pytest
import torch

from sim.cli import main
from sim.errors import CheckpointError, EvalError
from sim.evaluate import load_player
from sim.training.checkpoint import CHECKPOINT_VERSION, load_checkpoint, save_checkpoint
from sim.training.config import parse_config
from sim.training.trainer import train

TINY = {
    "name": "ckpt-test",
    "seed": 3,
    "total_steps": 256,
    "env": {"max_steps": 32, "observation": {"n_stack": 0}},
    "ppo": {"hidden": [8, 8], "minibatch_size": 64},
    "rollout": {"workers": 0, "envs_per_worker": 4, "steps_per_env": 32},
    "opponents": {"none": 1.0},
}


class _RunsCode:
    """Unpickling this makes a folder: the stand-in for any code a crafted file would run."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str]]:
        return (os.makedirs, (str(self.marker),))


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("ckpt") / "run"
    train(parse_config(TINY), folder, progress=False, export=False)
    return folder


def test_a_crafted_pickle_is_refused_without_running_it(tmp_path: Path, capsys) -> None:
    marker = tmp_path / "ran"
    evil = tmp_path / "evil.pt"
    torch.save({"version": CHECKPOINT_VERSION, "config": _RunsCode(marker)}, evil)
    with pytest.raises(CheckpointError, match=r"refused.*os\.makedirs.*could run code") as info:
        load_checkpoint(evil)
    assert "weights_only=False" not in str(info.value), "never advise the unsafe load"
    assert main(["export", "--checkpoint", str(evil), "--out", str(tmp_path / "x")]) == 2
    assert "refused" in capsys.readouterr().err
    with pytest.raises(EvalError, match="refused"):
        load_player(str(evil))
    assert not marker.exists(), "nothing in the file ran"
    # The control: the file really runs code when unpickled without the restriction.
    torch.load(evil, weights_only=False)
    assert marker.is_dir()


def test_files_that_are_not_checkpoints_are_named(tmp_path: Path) -> None:
    text = tmp_path / "notes.pt"
    text.write_text("not a checkpoint")
    with pytest.raises(CheckpointError, match="not a torch checkpoint"):
        load_checkpoint(text)
    other = tmp_path / "weights.pt"
    torch.save({"w": torch.zeros(2)}, other)
    with pytest.raises(CheckpointError, match="not a checkpoint of this trainer"):
        load_checkpoint(other)
    with pytest.raises(FileNotFoundError, match="no checkpoint"):
        load_checkpoint(tmp_path / "none.pt")


class _Kind(IntEnum):
    A = 1


def test_what_is_not_a_tensor_is_stored_as_plain_data(tmp_path: Path) -> None:
    sd = OrderedDict(w=torch.ones(2))
    sd._metadata = OrderedDict({"": {"version": 1}})  # type: ignore[attr-defined]
    state = {
        "rng": np.random.default_rng(1).bit_generator.state,
        "elo": np.float64(1012.5),
        "ret": np.zeros(3),
        "kind": _Kind.A,
        "betas": (0.9, 0.999),
        "opt": {0: {"step": torch.tensor(3.0)}},
        "agent": sd,
    }
    path = save_checkpoint(tmp_path / "c.pt", state)
    back = torch.load(path, weights_only=True)  # what load_checkpoint does
    assert back["rng"] == state["rng"]
    assert type(back["elo"]) is float and back["elo"] == 1012.5
    assert back["ret"] == [0.0, 0.0, 0.0]
    assert type(back["kind"]) is int and back["kind"] == 1
    assert back["betas"] == (0.9, 0.999) and list(back["opt"]) == [0]
    assert back["agent"]._metadata == {"": {"version": 1}}
    with pytest.raises(CheckpointError, match=r"checkpoint\.cfg\.where is a pathlib\.\w*Path"):
        save_checkpoint(tmp_path / "d.pt", {"cfg": {"where": Path("/x")}})
    assert not (tmp_path / "d.pt").exists()


def test_resume_export_and_a_pt_player_work_from_a_safe_load(run: Path, tmp_path: Path) -> None:
    latest = run / "checkpoints" / "latest.pt"
    state = load_checkpoint(latest)
    assert state["step"] == 256 and isinstance(state["config"], dict)
    assert main(["export", "--checkpoint", str(latest), "--out", str(tmp_path / "exp")]) == 0
    assert (tmp_path / "exp" / "policy.onnx").is_file()
    assert load_player(str(latest)).spec is not None
    resumed = train(
        replace(parse_config(TINY), total_steps=384), run, resume=True, progress=False,
        export=False,
    )  # fmt: skip
    assert resumed.steps == 384


def test_export_sets_skill_controller_settings_and_refuses_the_rest(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`pete-sim export --skill KEY=VALUE` changes how the options are driven in policy.json
    and records it; keys that would change the options, bad values and settings the observation
    cannot serve are refused with the reason; a drive policy has no skills to set."""
    import json

    skills = {"ring_options": 2, "goal_options": 0}
    cfg = parse_config({**TINY, "env": {**TINY["env"], "skills": skills}})
    folder = tmp_path / "skills"
    train(cfg, folder, progress=False, export=False)
    latest = str(folder / "checkpoints" / "latest.pt")
    out = tmp_path / "exp"
    rc = main([
        "export", "--checkpoint", latest, "--out", str(out), "--skill", "split_margin_m=0.5",
        "--skill", "lookahead_m = 0.4",
    ])  # fmt: skip
    assert rc == 0
    meta = json.loads((out / "policy.json").read_text())
    assert meta["actions"]["skills"]["split_margin_m"] == 0.5
    assert meta["actions"]["skills"]["lookahead_m"] == 0.4
    assert meta["training"]["skills_set"] == {"split_margin_m": 0.5, "lookahead_m": 0.4}
    capsys.readouterr()
    for word, why in (
        ("ring_options=3", "KEY one of"),
        ("split_margin_m=-1", "out of range"),
        ("share_platform=yes", "not a TOML value"),
        ("share_platform=true", "role flag"),
    ):
        rc = main(["export", "--checkpoint", latest, "--out", str(out), "--skill", word])
        assert rc == 2 and why in capsys.readouterr().err, word
    drive = str(run / "checkpoints" / "latest.pt")
    assert main(["export", "--checkpoint", drive, "--out", str(out), "--skill", "turn_gain=3"]) == 2
    assert "no skills" in capsys.readouterr().err
