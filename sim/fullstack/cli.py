"""`pete-sim match`: the command line of the full-stack match (sim/fullstack/README.md).

Light at import (argparse only): `pete-sim --help` must not load PyBullet or onnxruntime.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

FAULT_NAMES = (
    "link-cut", "corruption", "jetson-killed", "schema-mismatch", "camera-stops",
    "jetson-sigterm", "jetson-sigkill", "disk-full", "brain-reboot", "vexlink-lost",
)  # fmt: skip


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT, e.g. 320x240, got {text!r}"
        ) from exc
    return w, h


def add_match_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "match",
        help="one match of the whole stack (brain_host + wire + Jetson daemon) or of the policy",
        description="One seeded match. --stack full: brain_host runs the Brain core against the "
        "simulated hardware, the Jetson daemon runs perception on rendered frames and the "
        "policy, and they talk over a pty with the V5 USB bytes; lockstep (deterministic, "
        "faster than real time) unless --realtime. --stack sim: the policy directly in the "
        "simulator. Writes summary.txt/json, replay.gif (camera inset), plots.png, timeline.csv "
        "and the daemon's log to --out.",
    )
    p.add_argument(
        "--stack", choices=("full", "sim"), default="full", help="the whole stack, or the policy"
    )
    p.add_argument("--seed", type=int, default=0, help="match seed")
    p.add_argument(
        "--policy",
        type=Path,
        default=None,
        help="policy.onnx (policy.json beside it) (default: jetson/models/policy/policy.onnx); "
        "with --world, the policy on our robots' Jetsons instead of the scripted alliance (a "
        "learned alliance: sim/configs/alliance.toml)",
    )
    p.add_argument(
        "--opponent", default="planner", help="planner, scripted, idle, a policy.onnx, or none"
    )
    p.add_argument("--seconds", type=float, default=None, help="stop the match early")
    p.add_argument("--realtime", action="store_true", help="run on the wall clock, not lockstep")
    p.add_argument("--fault", choices=FAULT_NAMES, default=None, help="a fault scenario")
    p.add_argument(
        "--fault-at", type=float, default=None, help="match time of the fault, s (default: 1/3)"
    )
    p.add_argument(
        "--faults",
        default=None,
        metavar="NAME@S,...",
        help="several faults in one match, e.g. link-cut@10,jetson-sigterm@25 (instead of --fault)",
    )
    p.add_argument(
        "--daemon",
        choices=("inprocess", "process"),
        default=None,
        help="the Jetson daemon in this process, or as its own process (real signals) "
        "(default: its own process for the faults that need one)",
    )
    p.add_argument(
        "--scenario",
        choices=("capped", "uncapped"),
        default="capped",
        help="capped: the report's 10-ring task; uncapped: every ring counts",
    )
    p.add_argument("--no-camera", action="store_true", help="no frames: the policy sees no rings")
    p.add_argument(
        "--no-ring-counter",
        action="store_true",
        help="a robot without an intake ring counter (the State says 255; the daemon assumes 0)",
    )
    p.add_argument(
        "--gps-occlusion",
        action="store_true",
        help="the GPS loses the field strip behind robots, goals and platforms (the Brain's pose "
        "rides through on odometry and its IMU); default: a GPS that never fails",
    )
    p.add_argument(
        "--camera-size", type=_size, default=(240, 180), help="rendered frames (default: 240x180)"
    )
    p.add_argument("--camera-hz", type=float, default=10.0, help="frames per second")
    p.add_argument(
        "--detector",
        choices=("auto", "cnn", "classical"),
        default="auto",
        help="auto: the CNN when jetson/models/ringnet.onnx exists, else classical",
    )
    p.add_argument(
        "--detector-model", type=Path, default=None, help="CNN weights, .onnx (default: shipped)"
    )
    p.add_argument(
        "--perception-latency",
        type=float,
        default=0.05,
        help="s from a frame to its result reaching the policy (in lockstep)",
    )
    p.add_argument("--no-gif", action="store_true", help="no replay.gif")
    p.add_argument("--gif-every", type=float, default=0.5, help="match seconds per GIF frame")
    p.add_argument("--gif-size", type=int, default=400, help="GIF width in pixels")
    p.add_argument("--no-plots", action="store_true", help="no plots.png")
    p.add_argument(
        "--record", action="store_true", help="keep the daemon's session (pete-jetson replay)"
    )
    p.add_argument(
        "--dashboard",
        metavar="[HOST:]PORT",
        default=None,
        help="serve the daemon's read-only live dashboard here (a port alone: 127.0.0.1) "
        "(default: off)",
    )
    p.add_argument(
        "--partner",
        default="alliance",
        help="the whole game (--world): who drives our robot's partner (our robot is the red "
        '24" on the full stack): a player name in the twin, or "stack": the partner on the full '
        "stack too, its own Brain, daemon and camera, the two Brains linked by VEXlink "
        "(default: alliance)",
    )
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/match-...)")
    p.add_argument("--brain-host", type=Path, default=None, help="the brain_host binary")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=cmd_match)


def cmd_match(args: argparse.Namespace) -> int:
    import json

    from sim.errors import MatchError
    from sim.fullstack.faults import parse_schedule
    from sim.fullstack.options import DEFAULT_POLICY, MatchOptions
    from sim.fullstack.runner import run_match

    out = args.out
    if out is None:
        fault = args.fault or ("faults" if args.faults else None)
        tag = args.stack + (f"-{fault}" if fault else "") + f"-seed{args.seed}"
        out = Path("runs") / f"match-{tag}"
    try:
        faults = parse_schedule(args.faults) if args.faults else ()
        options = MatchOptions(
            stack=args.stack,
            seed=args.seed,
            policy=args.policy or DEFAULT_POLICY,
            opponent=args.opponent,
            seconds=args.seconds,
            realtime=args.realtime,
            fault=args.fault,
            fault_at_s=args.fault_at,
            faults=faults,
            daemon=args.daemon,
            scenario=args.scenario,
            camera=not args.no_camera,
            ring_counter=not args.no_ring_counter,
            gps_occlusion=args.gps_occlusion,
            camera_width=args.camera_size[0],
            camera_height=args.camera_size[1],
            camera_hz=args.camera_hz,
            detector=args.detector,
            detector_model=args.detector_model,
            perception_latency_s=args.perception_latency,
            gif=not args.no_gif,
            gif_every_s=args.gif_every,
            gif_size=args.gif_size,
            plots=not args.no_plots,
            record=args.record,
            out=out,
            brain_host=args.brain_host,
            dashboard=args.dashboard,
            world=getattr(args, "world", None),
            partner=args.partner,
            # In the whole game a policy named on the command line decides on our robots.
            player="policy" if args.policy and getattr(args, "world", None) else None,
        )
        progress = None if args.quiet or args.json else (lambda m: print(m, flush=True))
        result = run_match(options, progress)
    except MatchError as exc:
        print(f"pete-sim match: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result.as_dict(), indent=1, default=str))
    else:
        print(result.table())
        print(f"run folder: {out}")
        if "gif" in result.files:
            print(f"replay: {result.files['gif']}")
    return 0 if result.passed else 1
