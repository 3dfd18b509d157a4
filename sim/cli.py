"""`pete-sim`: the digital twin of the field, training and evaluation. Commands arrive with the
parts they drive."""

from __future__ import annotations

import argparse
import importlib.metadata
import sys
from pathlib import Path

DESCRIPTION = """\
The simulator side of Pac-Man Pete: a PyBullet twin of the Tipping Point field, Gymnasium and
PettingZoo environments, PPO self-play training and evaluation.

  pete-sim versions        the simulation stack this environment has installed
  pete-sim view            a PNG of a seeded field and a GIF of a scripted match
"""

_STACK = ("pacman-pete", "pybullet", "gymnasium", "pettingzoo", "torch", "numpy", "onnxruntime")


def _cmd_versions(_: argparse.Namespace) -> int:
    missing = 0
    for name in _STACK:
        try:
            version = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            version = "not installed (pip install 'pacman-pete[sim]')"
            missing += 1
        print(f"{name:<14} {version}")
    return 1 if missing else 0


def _cmd_view(args: argparse.Namespace) -> int:
    # Imported here: `pete-sim versions` must work where PyBullet is missing.
    from sim.view import write_view

    try:
        written = write_view(
            seed=args.seed,
            out=args.out,
            fidelity=args.fidelity,
            stride=args.stride,
            size=args.size,
            seconds=args.seconds,
            gif=not args.no_gif,
            camera=not args.no_camera,
        )
    except (ValueError, OSError) as e:
        print(f"pete-sim view: {e}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pete-sim",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("versions", help="print the installed simulation stack's versions")
    p.set_defaults(func=_cmd_versions)

    p = sub.add_parser(
        "view",
        help="write start.png and match.gif (scripted robots) for a seed",
        description="Render the field for a seed (start.png, camera.png) and a scripted match "
        "between two greedy ring-chasers (match.gif).",
    )
    p.add_argument("--seed", type=int, default=0, help="match seed (default 0)")
    p.add_argument("--out", type=Path, default=Path("sim-view"), help="output folder")
    p.add_argument("--fidelity", choices=("training", "high"), default="training")
    p.add_argument("--stride", type=int, default=4, help="control steps per GIF frame")
    p.add_argument("--size", type=int, default=480, help="image width in pixels")
    p.add_argument("--seconds", type=float, default=None, help="stop the match early")
    p.add_argument("--no-gif", action="store_true", help="only the start images")
    p.add_argument("--no-camera", action="store_true", help="skip the camera render")
    p.set_defaults(func=_cmd_view)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
