"""RESULTS.md and the README's headline table, generated from bench/results/*.json.

    python -m bench.report            # write RESULTS.md and README.md's headline block
    python -m bench.report --check    # write nothing; exit 1 naming each file that is stale
        [--results DIR] [--out RESULTS.md] [--readme README.md]

Every file in the results folder with the benchmark shape (bench.common: "benchmark",
"metrics", "targets", "machine", "date") becomes one section of RESULTS.md: what it measures,
the command that reproduces it, the machine and the date, its targets (target, value, met) and
all its metrics. A JSON file with none of those keys (NAME_details.json: per-match rows) is
listed as supporting data; a file with some of them but not the whole shape is an error that
names the file. README.md's block between `<!-- results:begin -->` and `<!-- results:end -->`
is rewritten with a few headline figures from the same files.

The output is a function of the JSON files and this module only: benchmarks sorted by name,
metrics and targets in the order their file holds them, every number through one formatter.
So `make results` regenerates RESULTS.md byte for byte, and `make check` runs --check, which
fails when a result file changed and RESULTS.md or the README block was not regenerated.

A new benchmark whose file is bench/NAME.py and whose result is NAME.json needs nothing here;
a result written under another name (`bench.train --name ...`) needs its command in SOURCES.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import re
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bench.common import OPS, RESULTS_DIR

REPO = Path(__file__).resolve().parent.parent
BENCH_DIR = Path(__file__).resolve().parent
RESULTS_MD = REPO / "RESULTS.md"
README_MD = REPO / "README.md"
BEGIN = "<!-- results:begin -->"
END = "<!-- results:end -->"
SHAPE = ("benchmark", "metrics", "targets", "machine", "date")
TARGET_SHAPE = ("target", "op", "met")
DATE = re.compile(r"\d{4}-\d{2}-\d{2}")
PERCEPTION_REAL = (
    "--real ../shared/datasets/blrsai-rings/train "
    "--real BLRSAI/dataset/roboflow_dataset/valid --real BLRSAI/dataset/roboflow_dataset/test"
)


class ReportError(Exception):
    """A result file that cannot be reported; the message names the file."""


@dataclass(frozen=True)
class Source:
    """How a result file is produced, and what it measures."""

    command: str
    about: str = ""


# What each committed result measures and the exact command that wrote it. A benchmark missing
# here is reproduced by `python -m bench.NAME` when bench/NAME.py exists.
SOURCES: dict[str, Source] = {
    "alliance": Source(
        "python -m bench.alliance",
        "The alliance (issue 46). The learned alliance (`learned_*`: one policy on both robots, "
        "sim/configs/alliance.toml) against the scripted alliance, sides swapped per seed: win "
        "rate, score, partner collisions a match, in the fidelity `learned_high_fidelity` says "
        "(1 high, 0 training); against itself (red's win rate) and against the ring-race "
        "alliance. The full stack: whole-game lockstep matches with both red robots on their own "
        "`brain_host`, daemon and camera, the two Brains linked by the twin's VEXlink, the "
        "scripted alliance on both sides: wall time of a match, red's score against the twin's "
        "own on the same seeds, VEXlink frames lost and late, and a `vexlink-lost` match's "
        "checks. `--part learned|stack` reruns one half and keeps the other's rows.",
    ),
    "brain_loop": Source(
        "python -m bench.brain_loop",
        "Host CPU time of one step of the Brain core's 10 ms loop (`brain_loop_bench`, built by "
        "`make build`): a normal match's traffic (nominal) and the most garbage a step decodes "
        "(flood).",
    ),
    "daemon": Source(
        "python -m bench.daemon",
        "The Jetson daemon's State -> Command latency over a pty with the shipped policy: its "
        "own part and the round trip, without and with the camera thread beside the loop.",
    ),
    "dashboard": Source(
        "python -m bench.dashboard",
        "What the live dashboard costs the robot and what a browser gets (issue 43): the daemon "
        "in its own process with the camera in its own, States at 100 Hz, without the dashboard, "
        "with it open in headless Chromium, and with the same page in Chromium fed the same "
        "messages without a dashboard (the browser's load alone): the daemon's State -> Command "
        "p50/p99 of each and their ratios, the process's CPU, the snapshots and camera frames a "
        "second the page counts.",
    ),
    "deploy": Source(
        "python -m bench.deploy",
        "How exposed the Jetson daemon's systemd unit (jetson/deploy/pete-jetson.service) leaves "
        "the system, as `systemd-analyze security --offline=true` rates it: 0 locked down, 10 "
        "nothing restricted; up to 4.0 systemd calls it OK.",
    ),
    "dropouts": Source(
        "python -m bench.dropouts",
        'The pose through GPS dropouts (issue 44): whole-game full-stack matches, the red 24" '
        "running the scripted alliance, each seed with the GPS strip hidden behind robots, goals "
        "and platforms and with a GPS that never fails: red's score each way and their ratio, "
        "how long the GPS was hidden, the Brain's pose error against the truth.",
    ),
    "match": Source(
        "python -m bench.match",
        "Full 105 s lockstep matches of the full stack (`brain_host`, the wire, the daemon with "
        "perception on rendered frames) against the same policy played directly in the "
        "simulator, the planner opposite: rings, points, wall time, loop latency, perception "
        "F1 against the simulator's truth, messages lost.",
    ),
    "perception": Source(
        f"python -m bench.perception {PERCEPTION_REAL}",
        "Ring detection (precision, recall, F1 at IoU 0.5) and localisation error on the "
        "simulator's test frames (`sim_`) and on real photos: real1 the shared BLRSAI photos "
        "the CNN held out, real2 and real3 the BLRSAI export's validation and test splits "
        "(a clone as in jetson/perception/README.md), `real_` all of them pooled; frames per "
        "second of the whole pipeline on one core.",
    ),
    "protocol": Source(
        "python -m bench.protocol",
        "Bytes on the wire against the original team's ASCII link, the Python codec's round "
        "trips per second on one core, and the C++ codec's times (`pete_codec_bench`, built by "
        "`make build`).",
    ),
    "sight": Source(
        "python -m bench.sight",
        "What the robot sees besides rings (issue 46), per class: red, blue, neutral and the "
        "tall neutral goal, red (the partner) and blue robots, on 1,200 random scenes of the 2v2 "
        "field rendered at the full stack's 240x180 from the red 24\"'s camera: precision, "
        "recall and F1 of the goal and robot detectors against the twin's sighting within 2 m "
        "(goals: sim.goal_sight; robots: the plates sim.visibility.plates_in_view sees), the "
        "true sightings' median localisation error, and frames per second of both detectors "
        "(and of the ring pipeline with them) on one core. Misses by cause in sight_details.json "
        "(docs/notes/2026-11-28-sight-benchmark.md).",
    ),
    "sim": Source(
        "python -m bench.sim",
        "Control steps per second of the simulator for a full seeded match: the Gymnasium env "
        "in training and high fidelity, with and without a rendered camera frame, the bare "
        "world, and several processes at once.",
    ),
    "soak": Source(
        "python -m bench.soak",
        "Lockstep full-stack matches with hundreds of faults at random moments (the cable pulled, "
        "SIGTERM and SIGKILL to the daemon's process and systemd's restart, the camera stopped, "
        "1 % corrupted bytes, a full disk, the Brain rebooted; these matches render a 96x72 "
        "camera at 5 Hz), and per seed the fault-free match against the same with the cable "
        "pulled for 2 s (default options): Commands driving that were stale or not as sent, "
        "stop and exit times, reconnects, the log's rate, rings lost "
        "(sim/fullstack/README.md, The fault soak).",
    ),
    "train": Source(
        "python -m bench.train",
        "Training and the shipped policy: the capped task learned from scratch (competence), "
        "rings per uncapped match against the scripted chaser (strength) and head-to-head win "
        "rates, for the policy beside the planner, the original team's policy and a random "
        "policy, in training fidelity and (fewer matches) high fidelity.",
    ),
    "train_high": Source(
        "python -m bench.train --skip-competence --fidelity high --players ours,planner "
        "--rows strength,h2h --matches-high 100 --matches-h2h-high 40 --name train_high",
        "bench.train's strength and head-to-head rows in high fidelity with 100 and 40 matches: "
        "the policy and the planner.",
    ),
    "train_high_planner": Source(
        "python -m bench.train --skip-competence --fidelity high --players planner "
        "--rows strength --matches-high 100 --name train_high_planner",
        "bench.train's high-fidelity strength row for the planner alone, 100 matches.",
    ),
}


@dataclass(frozen=True)
class Headline:
    """One row of README.md's headline table: `{KEY}` in `value` is a metric of `benchmark`,
    `{KEY:pct}` the same as a percentage."""

    label: str
    benchmark: str
    value: str


HEADLINES: tuple[Headline, ...] = (
    Headline(
        "Rings a match against the scripted chaser (mean +- 95 % interval): the policy vs "
        "the planner",
        "train",
        "{uncapped_rings_ours} +- {uncapped_rings_ci95_ours} vs "
        "{uncapped_rings_planner} +- {uncapped_rings_ci95_planner}",
    ),
    Headline(
        "The same in high fidelity",
        "train_high",
        "{uncapped_rings_ours_high} +- {uncapped_rings_ci95_ours_high} vs "
        "{uncapped_rings_planner_high} +- {uncapped_rings_ci95_planner_high}",
    ),
    Headline(
        "Head-to-head win rate of the policy: vs the planner, vs the original team's",
        "train",
        "{h2h_win_rate_ours_vs_planner:pct}, {h2h_win_rate_ours_vs_original:pct}",
    ),
    Headline(
        "Training on the fast backend vs on PyBullet: PPO end to end; bench.train's competence",
        "fastpath",
        "{fast_ppo_steps_per_s} vs {pybullet_ppo_steps_per_s} steps/s; "
        "{fast_competence_wall_s} s vs {pybullet_competence_wall_s} s",
    ),
    Headline(
        "The whole 2v2 game on the fast backend vs on PyBullet, robot steps with observations",
        "fastpath",
        "{fast_game_2v2_robot_steps_per_s} vs {pybullet_game_2v2_robot_steps_per_s} /s",
    ),
    Headline(
        "Full stack over the policy directly in the simulator: rings, points",
        "match",
        "{rings_full_over_sim}, {score_full_over_sim}",
    ),
    Headline(
        "The learned alliance against the scripted one: wins, points over its points, partner "
        "collisions a match",
        "alliance",
        "{learned_vs_scripted_win_rate:pct}, {learned_score_over_scripted}, "
        "{learned_partner_collisions_per_match}",
    ),
    Headline(
        "Both red robots on the full stack over VEXlink: a 2v2 match's wall time; radio frames "
        "lost; red's points over the twin's",
        "alliance",
        "{full_stack_2v2_wall_s_median} s; {vexlink_lost_share:pct}; {full_stack_score_over_twin}",
    ),
    Headline(
        "Ring detector: F1 on real photos (pooled), on simulator frames; speed on one core",
        "perception",
        "{real_cnn_f1} ({real_images} photos), {sim_cnn_f1}; {fps_cnn} frames/s",
    ),
    Headline(
        "State -> Command p99: the daemon, the round trip over a pty",
        "daemon",
        "{daemon_p99_ms} ms, {round_trip_p99_ms} ms",
    ),
    Headline(
        "The daemon's systemd unit: exposure as systemd-analyze rates it (0 locked down, 10 open)",
        "deploy",
        "{systemd_exposure}",
    ),
    Headline(
        "Python State encode + decode on one core",
        "protocol",
        "{state_roundtrips_per_s} round trips/s",
    ),
)


@dataclass(frozen=True)
class Target:
    target: float
    op: str
    met: bool


@dataclass(frozen=True)
class Benchmark:
    name: str
    path: Path
    metrics: dict[str, float]
    targets: dict[str, Target]
    machine: str
    date: str


@dataclass(frozen=True)
class Results:
    benchmarks: tuple[Benchmark, ...]
    supporting: tuple[Path, ...]


def fmt(value: float) -> str:
    """Every number in RESULTS.md and the headline: whole numbers with thousands separators,
    others to 4 significant digits (from 1,000 up: to the unit)."""
    if isinstance(value, int) or (float(value).is_integer() and abs(value) < 1e15):
        return f"{int(value):,}"
    if abs(value) >= 1000:
        return f"{value:,.0f}"
    return f"{value:.4g}"


def pct(value: float) -> str:
    return f"{fmt(round(value * 100, 1))} %"


def _is_number(value: object) -> bool:
    return not isinstance(value, bool) and isinstance(value, int | float) and math.isfinite(value)


def load_file(path: Path) -> Benchmark | None:
    """The benchmark in `path`, or None when the file is supporting data (JSON that has none of
    the benchmark keys). Raises ReportError, naming the file, for anything else."""
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ReportError(f"{path}: not readable JSON ({exc})") from None
    if not isinstance(data, dict) or not set(SHAPE) & set(data):
        return None

    def bad(why: str) -> ReportError:
        return ReportError(f"{path}: not a benchmark result: {why} (the shape: bench/common.py)")

    missing = [k for k in SHAPE if k not in data]
    if missing:
        hint = ""
        if missing == ["date"]:
            hint = "; bench.common writes it, an older file takes `git log -1 --format=%cs -- FILE`"
        raise bad(f"no {', '.join(repr(k) for k in missing)}{hint}")
    extra = sorted(set(data) - set(SHAPE))
    if extra:
        raise bad(f"unexpected keys {extra}")
    name = data["benchmark"]
    if name != path.stem:
        raise bad(f'"benchmark" is {name!r}, not the file\'s name {path.stem!r}')
    if not isinstance(data["machine"], str) or not data["machine"].strip():
        raise bad('"machine" must be a non-empty string')
    date = data["date"]
    if not isinstance(date, str) or not DATE.fullmatch(date):
        raise bad(f'"date" must be YYYY-MM-DD, got {date!r}')
    try:
        datetime.date.fromisoformat(date)
    except ValueError:
        raise bad(f'"date" {date!r} is no calendar date') from None
    metrics = data["metrics"]
    if not isinstance(metrics, dict):
        raise bad('"metrics" must be an object')
    for key, value in metrics.items():
        if not _is_number(value):
            raise bad(f"metric {key!r} is {value!r}, not a finite number")
    targets = data["targets"]
    if not isinstance(targets, dict):
        raise bad('"targets" must be an object')
    parsed = {}
    for key, t in targets.items():
        if not isinstance(t, dict) or sorted(t) != sorted(TARGET_SHAPE):
            raise bad(f"target {key!r} must be {{'target', 'op', 'met'}}, got {t!r}")
        if not _is_number(t["target"]) or t["op"] not in OPS or not isinstance(t["met"], bool):
            raise bad(f"target {key!r}: {t!r}")
        parsed[key] = Target(t["target"], t["op"], t["met"])
    return Benchmark(name, path, dict(metrics), parsed, data["machine"], date)


def load(directory: Path) -> Results:
    """Every *.json in `directory`, sorted by name; raises ReportError naming a bad file."""
    if not directory.is_dir():
        raise ReportError(f"{directory}: no such folder")
    benchmarks, supporting = [], []
    for path in sorted(directory.glob("*.json")):
        bench = load_file(path)
        if bench is None:
            supporting.append(path)
        else:
            benchmarks.append(bench)
    return Results(tuple(benchmarks), tuple(supporting))


def source(bench: Benchmark) -> Source:
    if bench.name in SOURCES:
        return SOURCES[bench.name]
    if (BENCH_DIR / f"{bench.name}.py").is_file():
        return Source(f"python -m bench.{bench.name}")
    raise ReportError(
        f"{bench.path}: no bench/{bench.name}.py and no command for it in bench/report.py's "
        "SOURCES: say there how it is reproduced"
    )


def _link(path: Path, start: Path) -> str:
    return Path(os.path.relpath(path.resolve(), start.resolve())).as_posix()


def _table(header: Sequence[str], rows: Sequence[Sequence[str]], right: Sequence[bool]) -> str:
    lines = ["| " + " | ".join(header) + " |"]
    lines.append("|" + "|".join("---:" if r else "---" for r in right) + "|")
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _met(bench: Benchmark) -> str:
    met = sum(t.met for t in bench.targets.values())
    return f"{met} of {len(bench.targets)}" if bench.targets else "no targets"


def render_results(results: Results, out: Path) -> str:
    """The text of RESULTS.md, for a file at `out` (links are relative to its folder)."""
    here = out.parent
    parts = [
        "# Results",
        "",
        "<!-- Generated by `python -m bench.report` (`make results`) from bench/results/*.json."
        " Do not edit: run the benchmark, then `make results`. -->",
        "",
        "Every figure the project quotes comes from a benchmark's result file in "
        "`bench/results/`, written by the command beside it. `make bench` runs every benchmark "
        "with its defaults, `make results` regenerates this page, and `make check` fails when "
        "the page is stale. Timings depend on the machine named with them.",
        "",
    ]
    rows = [[f"[{b.name}](#{b.name})", _met(b), b.date, b.machine] for b in results.benchmarks]
    parts += [
        _table(["benchmark", "targets met", "date", "machine"], rows, [False] * 4),
        "",
    ]
    by_stem = {p.stem: p for p in results.supporting}
    listed: set[Path] = set()
    for b in results.benchmarks:
        src = source(b)
        parts += [f"## {b.name}", ""]
        if src.about:
            parts += [src.about, ""]
        parts += [
            "```sh",
            src.command,
            "```",
            "",
            f"Measured {b.date} on {b.machine}; the file: [{b.path.name}]({_link(b.path, here)}).",
            "",
        ]
        details = by_stem.get(f"{b.name}_details")
        if details is not None:
            listed.add(details)
            parts += [f"Per-match details: [{details.name}]({_link(details, here)}).", ""]
        if b.targets:
            rows = []
            for key, t in b.targets.items():
                value = fmt(b.metrics[key]) if key in b.metrics else "(missing)"
                rows.append(
                    [f"`{key}`", f"{t.op} {fmt(t.target)}", value, "yes" if t.met else "**no**"]
                )
            parts += [
                "Targets:",
                "",
                _table(["metric", "target", "value", "met"], rows, [False, False, True, False]),
                "",
            ]
        rows = [[f"`{key}`", fmt(value)] for key, value in b.metrics.items()]
        parts += [
            "Metrics:",
            "",
            _table(["metric", "value"], rows, [False, True]),
            "",
        ]
    others = [p for p in results.supporting if p not in listed]
    if others:
        parts += ["## Other files", ""]
        parts += [f"- [{p.name}]({_link(p, here)})" for p in others]
        parts.append("")
    return "\n".join(parts)


_FIELD = re.compile(r"\{(\w+)(?::(pct))?\}")


def render_headline(results: Results, results_md: str = "RESULTS.md") -> str:
    """The README's block between the markers, markers included. A headline whose benchmark is
    not in the results is left out; one whose metric is missing is an error."""
    benches = {b.name: b for b in results.benchmarks}
    rows = []
    for h in HEADLINES:
        bench = benches.get(h.benchmark)
        if bench is None:
            continue

        def field(m: re.Match[str], bench: Benchmark = bench) -> str:
            key, style = m.group(1), m.group(2)
            if key not in bench.metrics:
                raise ReportError(f"{bench.path}: no metric {key!r}, which README's headline reads")
            value = bench.metrics[key]
            return pct(value) if style == "pct" else fmt(value)

        value = _FIELD.sub(field, h.value)
        rows.append([h.label, value, f"[{bench.name}]({results_md}#{bench.name})"])
    lines = [
        BEGIN,
        "<!-- Generated by `make results` from bench/results/*.json: do not edit. -->",
        "",
        _table(["figure", "value", "benchmark"], rows, [False, True, False]),
        END,
    ]
    return "\n".join(lines)


def replace_block(text: str, block: str, path: Path) -> str:
    """`text` with the part from BEGIN to END (markers included) replaced by `block`."""
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start or text.count(BEGIN) != 1 or text.count(END) != 1:
        raise ReportError(f"{path}: needs one {BEGIN} line and one {END} line after it")
    return text[:start] + block + text[end + len(END) :]


def outputs(results_dir: Path, out: Path, readme: Path) -> dict[Path, str]:
    """What each generated file must hold."""
    results = load(results_dir)
    wanted = {out: render_results(results, out)}
    try:
        text = readme.read_text()
    except OSError as exc:
        raise ReportError(f"{readme}: {exc.strerror}") from None
    link = _link(out, readme.parent)
    wanted[readme] = replace_block(text, render_headline(results, link), readme)
    return wanted


def _display(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.report",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--results", type=Path, default=RESULTS_DIR, help="the JSON folder")
    parser.add_argument("--out", type=Path, default=RESULTS_MD, help="RESULTS.md to write")
    parser.add_argument("--readme", type=Path, default=README_MD, help="README with the markers")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 when stale")
    args = parser.parse_args(argv)
    try:
        wanted = outputs(args.results, args.out, args.readme)
    except ReportError as exc:
        print(f"bench.report: {exc}", file=sys.stderr)
        return 2
    stale = []
    for path, text in wanted.items():
        try:
            current = path.read_text()
        except OSError:
            current = None
        if current == text:
            continue
        stale.append(path)
        if not args.check:
            path.write_text(text)
            print(f"wrote {_display(path)}")
    if args.check and stale:
        for path in stale:
            print(
                f"bench.report: {_display(path)} is stale: run `make results` "
                "(python -m bench.report)",
                file=sys.stderr,
            )
        return 1
    if not stale:
        print("bench.report: RESULTS.md and the README's headline are up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
