"""bench.report: RESULTS.md and the README's headline block from a folder of result files."""

from __future__ import annotations

import datetime
import json
from pathlib import Path

import pytest

import bench.report as report
from bench.common import RESULTS_DIR, Result

README = (
    "# Project\n\nText before.\n\n<!-- results:begin -->\nold\n<!-- results:end -->\n\nAfter.\n"
)


def _sim_result() -> Result:
    r = Result("sim")
    r.add("training_env_steps_per_s", 2370.8)
    r.add("training_match_s", 0.531)
    r.add("match_steps", 1260)
    r.target("training_env_steps_per_s", 1500.0, ">=")
    r.target("training_match_s", 0.84, "<=")
    return r


def _protocol_result() -> Result:
    r = Result("protocol")
    r.add("state_roundtrips_per_s", 494541)
    r.add("state_packet_decode_ns", 321.44)
    r.target("state_roundtrips_per_s", 200_000, ">=")
    r.target("state_packet_decode_ns", 100, "<=")  # not met
    return r


@pytest.fixture
def tree(tmp_path: Path) -> dict[str, Path]:
    """A results folder as the benchmarks write it, a README with the markers, and where
    RESULTS.md goes."""
    results = tmp_path / "bench" / "results"
    _sim_result().save(results)
    _protocol_result().save(results)
    (results / "sim_details.json").write_text(json.dumps({"per_match": [1, 2, 3]}))
    (results / "notes.json").write_text("[1, 2]\n")
    readme = tmp_path / "README.md"
    readme.write_text(README)
    return {"results": results, "out": tmp_path / "RESULTS.md", "readme": readme}


def _run(tree: dict[str, Path], *extra: str) -> int:
    return report.main(
        [
            "--results",
            str(tree["results"]),
            "--out",
            str(tree["out"]),
            "--readme",
            str(tree["readme"]),
            *extra,
        ]
    )


def test_the_writer_dates_each_result(tmp_path: Path) -> None:
    data = json.loads(_sim_result().save(tmp_path).read_text())
    assert data["date"] == datetime.date.today().isoformat()


def test_generates_every_benchmark_with_targets_machine_date_and_command(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(tree) == 0
    text = tree["out"].read_text()
    today = datetime.date.today().isoformat()
    # Sorted by name, whatever order the files were written in.
    assert text.index("## protocol") < text.index("## sim")
    assert "| [protocol](#protocol) | 1 of 2 | " + today in text
    assert "| [sim](#sim) | 2 of 2 | " + today in text
    assert "```sh\npython -m bench.sim\n```" in text
    # Fixed number formatting: separators for whole numbers, 4 significant digits otherwise.
    assert "| `training_env_steps_per_s` | >= 1,500 | 2,371 | yes |" in text
    assert "| `state_packet_decode_ns` | <= 100 | 321.4 | **no** |" in text
    assert "| `match_steps` | 1,260 |" in text
    # Supporting data: a NAME_details.json under its benchmark, anything else at the end.
    sim_section = text[text.index("## sim") :]
    assert "Per-match details: [sim_details.json](bench/results/sim_details.json)" in sim_section
    assert "## Other files\n\n- [notes.json](bench/results/notes.json)" in text
    assert "sim_details.json" not in text[text.index("## Other files") :]
    # The README: the block between the markers is replaced, nothing else moves.
    readme = tree["readme"].read_text()
    assert readme.startswith("# Project\n\nText before.\n\n<!-- results:begin -->\n")
    assert readme.endswith("<!-- results:end -->\n\nAfter.\n")
    assert "old" not in readme
    assert "| 494,541 round trips/s | [protocol](RESULTS.md#protocol) |" in readme
    # Headlines of benchmarks absent from the folder are left out.
    assert "[train]" not in readme


def test_output_is_deterministic(tree: dict[str, Path], tmp_path: Path) -> None:
    assert _run(tree) == 0
    first = tree["out"].read_bytes(), tree["readme"].read_bytes()
    assert _run(tree) == 0
    assert (tree["out"].read_bytes(), tree["readme"].read_bytes()) == first
    # The same files written in the other order, in another folder: the same page.
    other = tmp_path / "again"
    _protocol_result().save(other)
    for name in ("sim_details.json", "notes.json"):
        (other / name).write_text((tree["results"] / name).read_text())
    for name in ("sim.json", "protocol.json"):
        (other / name).write_text((tree["results"] / name).read_text())
    again = report.render_results(report.load(other), tree["out"])
    assert again == first[0].decode().replace("](bench/results/", "](again/")


def test_check_passes_when_fresh_and_names_each_stale_file(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(tree) == 0
    assert _run(tree, "--check") == 0
    results_md, readme = tree["out"].read_text(), tree["readme"].read_text()

    # A metric the headline reads: both files are stale.
    path = tree["results"] / "protocol.json"
    data = json.loads(path.read_text())
    data["metrics"]["state_roundtrips_per_s"] = 400_000
    path.write_text(json.dumps(data, indent=2) + "\n")
    capsys.readouterr()
    assert _run(tree, "--check") == 1
    err = capsys.readouterr().err
    assert "RESULTS.md is stale" in err and "README.md is stale" in err
    # --check writes nothing.
    assert tree["out"].read_text() == results_md and tree["readme"].read_text() == readme

    # Only RESULTS.md stale (a metric the headline does not read): only it is named.
    assert _run(tree) == 0
    path = tree["results"] / "sim.json"
    data = json.loads(path.read_text())
    data["metrics"]["training_env_steps_per_s"] = 2000.0
    path.write_text(json.dumps(data, indent=2) + "\n")
    capsys.readouterr()
    assert _run(tree, "--check") == 1
    err = capsys.readouterr().err
    assert "RESULTS.md is stale" in err and "README.md" not in err

    # A hand edit of the generated page is stale too.
    assert _run(tree) == 0
    tree["out"].write_text(tree["out"].read_text() + "A note by hand.\n")
    assert _run(tree, "--check") == 1


def test_check_fails_when_results_md_is_missing(tree: dict[str, Path]) -> None:
    assert _run(tree, "--check") == 1
    assert not tree["out"].exists()


def _shape(**changes: object) -> dict[str, object]:
    """A well-shaped result named "bad", with `changes` (None removes a key)."""
    data: dict[str, object] = {
        "benchmark": "bad",
        "metrics": {"x": 1.5},
        "targets": {"x": {"target": 1, "op": ">=", "met": True}},
        "machine": "m",
        "date": "2026-01-02",
    }
    data.update(changes)
    return {k: v for k, v in data.items() if v is not None}


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (_shape(targets=None, machine=None, date=None), "no 'targets', 'machine', 'date'"),
        (_shape(date=None), "no 'date'; bench.common writes it"),
        (_shape(benchmark="other"), "'other', not the file's name 'bad'"),
        (_shape(metrics={"x": "1"}), "metric 'x' is '1'"),
        (_shape(metrics={"x": True}), "metric 'x' is True"),
        (_shape(metrics=[1.5]), '"metrics" must be an object'),
        (_shape(targets={"x": {"target": 1, "op": "=="}}), "target 'x'"),
        (_shape(targets={"x": {"target": 1, "op": "==", "met": True}}), "target 'x'"),
        (_shape(machine=""), '"machine" must be a non-empty string'),
        (_shape(date="2026-13-40"), "no calendar date"),
        (_shape(date="26/11/2026"), "YYYY-MM-DD"),
        (_shape(extra=1), "unexpected keys ['extra']"),
    ],
)
def test_a_wrong_shaped_file_is_an_error_naming_it(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str], data: object, why: str
) -> None:
    bad = tree["results"] / "bad.json"
    bad.write_text(json.dumps(data))
    for args in ((), ("--check",)):
        capsys.readouterr()
        assert _run(tree, *args) == 2
        err = capsys.readouterr().err
        assert f"bench.report: {bad}: not a benchmark result: " in err
        assert why in err
    assert not tree["out"].exists()
    assert tree["readme"].read_text() == README


def test_unreadable_json_is_an_error_naming_it(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tree["results"] / "broken.json"
    bad.write_text('{"benchmark": ')
    assert _run(tree) == 2
    assert f"{bad}: not readable JSON" in capsys.readouterr().err


def test_a_benchmark_nobody_can_reproduce_is_an_error(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    r = Result("nowhere")
    r.add("x", 1.0)
    path = r.save(tree["results"])
    assert _run(tree) == 2
    err = capsys.readouterr().err
    assert f"{path}: no bench/nowhere.py and no command for it" in err


def test_readme_without_markers_is_an_error(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    tree["readme"].write_text("# Project\n")
    assert _run(tree) == 2
    assert "needs one <!-- results:begin --> line" in capsys.readouterr().err


def test_a_headline_metric_missing_from_its_benchmark_names_the_file(
    tree: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    r = Result("protocol")
    r.add("state_packet_decode_ns", 321.44)
    path = r.save(tree["results"])
    assert _run(tree) == 2
    err = capsys.readouterr().err
    assert f"{path}: no metric 'state_roundtrips_per_s', which README's headline reads" in err


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (0, "0"),
        (1260, "1,260"),
        (105.0, "105"),
        (494541.4, "494,541"),
        (0.9734939759036144, "0.9735"),
        (38.20714712300014, "38.21"),
        (0.005667512, "0.005668"),
        (-0.34, "-0.34"),
    ],
)
def test_number_format(value: float, text: str) -> None:
    assert report.fmt(value) == text


def test_percentages() -> None:
    assert report.pct(0.675) == "67.5 %"
    assert report.pct(0.8) == "80 %"
    assert report.pct(1.0) == "100 %"


def test_every_committed_result_loads_and_has_a_command() -> None:
    results = report.load(RESULTS_DIR)
    names = {b.name for b in results.benchmarks}
    assert {"match", "perception", "train", "train_high"} <= names
    for b in results.benchmarks:
        assert report.source(b).command.startswith("python -m bench.")
    # Every headline reads a committed benchmark and every metric it names.
    assert {h.benchmark for h in report.HEADLINES} <= names
    report.render_headline(results)
    assert {p.name for p in results.supporting} >= {"train_details.json"}
