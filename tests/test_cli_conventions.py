"""The conventions the three command lines share: --version, defaults in every --help, `train`
refusing a folder that holds a run, and progress displays only for a terminal."""

from __future__ import annotations

import argparse
import importlib.metadata
import io
import json
import re
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from jetson import cli as jetson_cli
from protocol import cli as protocol_cli
from protocol.cli_conventions import ProgressLine, progress_wanted
from protocol.messages import FINGERPRINT, PROTOCOL_VERSION
from sim import cli as sim_cli

CLIS: dict[str, Callable[[], argparse.ArgumentParser]] = {
    "pete-protocol": protocol_cli.build_parser,
    "pete-jetson": jetson_cli.build_parser,
    "pete-sim": sim_cli.build_parser,
}
MAINS = {
    "pete-protocol": protocol_cli.main,
    "pete-jetson": jetson_cli.main,
    "pete-sim": sim_cli.main,
}


def parsers(parser: argparse.ArgumentParser) -> Iterator[argparse.ArgumentParser]:
    """The parser and every subcommand's, depth first."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):  # aliases share a parser
                yield from parsers(sub)


def all_parsers() -> list[tuple[str, argparse.ArgumentParser]]:
    return [(p.prog, p) for build in CLIS.values() for p in parsers(build())]


@pytest.mark.parametrize("prog", CLIS)
def test_version_names_the_package_and_the_protocol(prog: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        MAINS[prog](["--version"])
    assert exit_info.value.code in (0, None)
    out = capsys.readouterr().out.strip()
    assert out.startswith(f"{prog} {importlib.metadata.version('pacman-pete')} ")
    assert f"schema fingerprint 0x{FINGERPRINT:08X}" in out
    assert f"protocol version {PROTOCOL_VERSION}" in out


def test_every_subcommand_shows_its_defaults_the_same_way() -> None:
    checked = 0
    for prog, parser in all_parsers():
        parser.format_help()  # every help renders (a stray % would raise here)
        formatter = parser._get_formatter()
        for action in parser._actions:
            if action.help is argparse.SUPPRESS or not action.option_strings:
                continue
            text = formatter._get_help_string(action) if action.help else ""
            where = f"{prog} {action.option_strings[0]}"
            if action.default not in (None, False, argparse.SUPPRESS) and not isinstance(
                action, argparse._HelpAction
            ):
                assert action.help, f"{where} has a default but no help to show it in"
                assert "(default: " in text, f"{where}: {text!r}"
                checked += 1
            # One form only: "(default: X)", never "(default X)", "default X" or a bare "(X)".
            written = action.help or ""
            assert not re.search(r"\(default [^:]|; default |^default", written), where
            if action.default not in (None, False, True, argparse.SUPPRESS, ""):
                assert f"({action.default})" not in written, f"{where}: {written!r}"
    assert checked > 40, "the walk reached the subcommands"


def test_a_one_paragraph_description_wraps_and_a_command_list_keeps_its_lines() -> None:
    top = sim_cli.build_parser().format_help()
    assert "  pete-sim train           PPO self-play" in top
    sub = dict(all_parsers())["pete-jetson detector train"].format_help()
    assert max(len(line) for line in sub.splitlines()) <= 100


# --- pete-sim train and an existing run folder -------------------------------------------------


@pytest.fixture
def fake_train(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, Any]]:
    """sim.training.trainer.train replaced by one that records its call and what the folder
    held then."""
    calls: list[dict[str, Any]] = []

    def train(cfg: Any, run_dir: Path, resume: bool = False, progress: bool = True, **_: Any):
        run_dir.mkdir(parents=True, exist_ok=True)  # as the real one does
        calls.append(
            {
                "resume": resume,
                "progress": progress,
                "held": sorted(p.name for p in run_dir.iterdir()),
            }
        )
        return SimpleNamespace(
            steps=1, wall_s=0.0, episodes=0, interrupted=False, run_dir=run_dir, policy=None
        )

    import sim.training.trainer

    monkeypatch.setattr(sim.training.trainer, "train", train)
    return calls


def _train(run: Path, *extra: str) -> int:
    return sim_cli.main(["train", "--config", "tiny", "--run-dir", str(run), *extra])


def test_train_refuses_a_folder_holding_a_run_unless_told(
    tmp_path: Path, capsys, fake_train
) -> None:
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    (run / "checkpoints" / "latest.pt").write_bytes(b"old")
    (run / "history.jsonl").write_text("{}\n")
    (run / "notes.txt").write_text("mine")
    assert _train(run) == 2
    err = capsys.readouterr().err
    assert "already holds a training run" in err and "--resume" in err and "--force" in err
    assert "checkpoints" in err and "history.jsonl" in err
    assert fake_train == [] and (run / "checkpoints" / "latest.pt").is_file()

    assert _train(run, "--resume", "--force") == 2
    assert "not both" in capsys.readouterr().err

    assert _train(run, "--resume") == 0
    assert fake_train[-1]["resume"] and "checkpoints" in fake_train[-1]["held"]

    assert _train(run, "--force") == 0
    assert fake_train[-1] == {"resume": False, "progress": False, "held": ["notes.txt"]}, (
        "--force deletes the earlier run's files and keeps the others"
    )


def test_train_takes_a_new_or_empty_folder(tmp_path: Path, fake_train) -> None:
    assert _train(tmp_path / "new") == 0
    (tmp_path / "empty").mkdir()
    assert _train(tmp_path / "empty") == 0
    assert len(fake_train) == 2


# --- progress -------------------------------------------------------------------------------------


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_for_a_terminal_only() -> None:
    assert progress_wanted(False, _Tty())
    assert not progress_wanted(True, _Tty())
    assert not progress_wanted(False, io.StringIO())
    closed = io.StringIO()
    closed.close()
    assert not progress_wanted(False, closed), "isatty on a closed stream raises ValueError"


def test_the_progress_line_reports_every_few_seconds_and_at_the_end() -> None:
    now = [0.0]
    out = io.StringIO()
    line = ProgressLine("detect", 10, "frames", every_s=2.0, stream=out, clock=lambda: now[0])
    for _ in range(4):
        now[0] += 0.5
        line.update()
    assert out.getvalue() == "detect: 4/10 frames (40 %), 2.0 frames/s, about 3 s left\n"
    now[0] += 0.5
    line.update()
    line.close()
    assert out.getvalue().splitlines()[-1] == "detect: 5/10 frames (50 %), 2.0 frames/s, 2 s"
    line.update()  # after close: silent
    assert line.lines == 2
    quiet = io.StringIO()
    with ProgressLine("x", None, enabled=False, stream=quiet) as off:
        off.update(5)
    assert quiet.getvalue() == "" and off.count == 5


@pytest.fixture
def tty(monkeypatch: pytest.MonkeyPatch) -> Callable[[bool], None]:
    def set_tty(on: bool) -> None:
        monkeypatch.setattr(sys.stdout, "isatty", lambda: on)

    return set_tty


def test_pete_sim_eval_draws_a_bar_only_on_a_terminal(monkeypatch, capsys, tty) -> None:
    import sim.evaluate

    def evaluate(a, b, matches, seed, progress=None, **_):  # type: ignore[no-untyped-def]
        for k in range(matches):
            progress(k + 1, matches)
        return SimpleNamespace(table=lambda: "table", as_dict=dict)

    monkeypatch.setattr(sim.evaluate, "evaluate", evaluate)
    args = ["eval", "--policy", "idle", "--opponent", "none", "--matches", "3"]
    for on, extra, shown in (
        (True, [], True),
        (False, [], False),
        (True, ["--no-progress"], False),
    ):
        tty(on)
        assert sim_cli.main(args + extra) == 0
        err = capsys.readouterr().err
        assert ("pete-sim eval" in err and "3/3" in err) == shown, (on, extra, err)


def test_pete_sim_dataset_draws_a_bar_only_on_a_terminal(monkeypatch, tmp_path, tty) -> None:
    import sim.dataset

    seen: list[bool] = []
    monkeypatch.setattr(
        sim.dataset, "write_dataset", lambda cfg, out, progress=False: seen.append(progress) or 0
    )
    for on, extra in ((True, []), (False, []), (True, ["--no-progress"])):
        tty(on)
        assert sim_cli.main(["dataset", "--frames", "1", "--out", str(tmp_path), *extra]) == 0
    assert seen == [True, False, False]


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("synth") / "data"
    assert jetson_cli.main(["detector", "synth", "--frames", "3", "--out", str(folder),
                            "--width", "320", "--height", "240"]) == 0  # fmt: skip
    return folder


def test_pete_jetson_detect_and_detector_eval_report_progress_on_a_terminal(
    synthetic: Path, tmp_path: Path, capsys, tty
) -> None:
    commands = {
        "pete-jetson detect: 3/3 frames (100 %)": [
            "detect", "--source", str(synthetic / "images"), "--out", str(tmp_path / "det"),
            "--detector", "classical",
        ],
        "pete-jetson detector eval: 3/3 images (100 %)": [
            "detector", "eval", "--images", str(synthetic), "--detector", "classical",
        ],
    }  # fmt: skip
    for line, argv in commands.items():
        for on, extra, shown in (
            (True, [], True),
            (False, [], False),
            (True, ["--no-progress"], False),
        ):
            tty(on)
            assert jetson_cli.main(argv + extra) == 0
            captured = capsys.readouterr()
            assert (line in captured.err) == shown, (argv, on, extra, captured.err)
            assert line not in captured.out, "progress goes to stderr, results to stdout"
    rings = (tmp_path / "det" / "rings.jsonl").read_text().splitlines()
    assert len(rings) == 3 and json.loads(rings[0])["index"] == 0
