"""`pete-sim`: the digital twin of the field, training and evaluation. Commands arrive with the
parts they drive."""

from __future__ import annotations

import argparse
import importlib.metadata
import sys

DESCRIPTION = """\
The simulator side of Pac-Man Pete: a PyBullet twin of the Tipping Point field, Gymnasium and
PettingZoo environments, PPO self-play training and evaluation.

  pete-sim versions        the simulation stack this environment has installed
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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pete-sim",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("versions", help="print the installed simulation stack's versions")
    p.set_defaults(func=_cmd_versions)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
