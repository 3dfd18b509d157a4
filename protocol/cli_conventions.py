"""What the three command lines (pete-protocol, pete-jetson, pete-sim) share.

- `--version` prints the package version and the wire protocol it speaks (version and schema
  fingerprint: a Brain and a Jetson talk only when the fingerprints agree).
- `--help`, of the program and of every subcommand, shows each option's default as
  "(default: X)"; an option whose help already says what happens without it ("(default: found
  over USB)") is left as written.
- Progress displays are on only when stdout is a terminal and --no-progress is not given. The
  simulator draws tqdm bars; the Jetson side, which does not install tqdm, prints a plain line
  every few seconds (ProgressLine).

Here, in the protocol package, because all three programs import it and it imports nothing else.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import sys
import time
from collections.abc import Callable
from types import TracebackType
from typing import Any, TextIO

PACKAGE = "pacman-pete"


def package_version() -> str:
    try:
        return importlib.metadata.version(PACKAGE)
    except importlib.metadata.PackageNotFoundError:
        return "(not installed: run from a checkout)"


def version_text(prog: str) -> str:
    """'pete-jetson 0.1.0 (protocol version 3, schema fingerprint 0x05AA25A9)'."""
    from protocol.messages import FINGERPRINT, PROTOCOL_VERSION

    return (
        f"{prog} {package_version()} (protocol version {PROTOCOL_VERSION}, "
        f"schema fingerprint 0x{FINGERPRINT:08X})"
    )


class HelpFormatter(argparse.HelpFormatter):
    """Descriptions written on several lines (command lists) keep their lines; one-paragraph
    descriptions are wrapped. Every option with a default other than None or False ends its help
    with "(default: X)", unless the help already names its default."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text.strip("\n"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "(default" in text or "%(default)" in text:
            return text
        default = action.default
        if default is None or default is False or default is argparse.SUPPRESS:
            return text
        if not action.option_strings and action.nargs not in (argparse.OPTIONAL, "*"):
            return text
        return f"{text} (default: %(default)s)"


class Parser(argparse.ArgumentParser):
    """An ArgumentParser with HelpFormatter; its subcommands' parsers are Parsers too (argparse
    makes them of the parent's class), so every `--help` follows the same rules."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)


class _VersionAction(argparse.Action):
    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs: Any):
        kwargs.setdefault("help", "print the package version and the protocol schema fingerprint")
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> None:
        prog = (parser.prog or "").split()[0]
        print(version_text(prog), file=sys.stdout, flush=True)
        parser.exit()


def make_parser(prog: str, description: str) -> Parser:
    """The top-level parser of one of our programs: HelpFormatter and --version."""
    parser = Parser(prog=prog, description=description)
    parser.add_argument("--version", action=_VersionAction)
    return parser


def add_no_progress(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress display (there is none anyway when stdout is not a terminal)",
    )


def progress_wanted(no_progress: bool, stdout: TextIO | None = None) -> bool:
    """A progress display is drawn only for a person watching: stdout is a terminal and
    --no-progress was not given."""
    if no_progress:
        return False
    stream = sys.stdout if stdout is None else stdout
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class ProgressLine:
    """Progress as a plain line on stderr every `every_s` seconds (and one at the end):
    "detect: 120/500 frames (24 %), 8.1 frames/s, about 47 s left". The Jetson side's progress
    display: no tqdm there, and a line is what a log or an SSH session shows best anyway."""

    def __init__(
        self,
        desc: str,
        total: int | None = None,
        unit: str = "frames",
        enabled: bool = True,
        every_s: float = 2.0,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.desc = desc
        self.total = total
        self.unit = unit
        self.enabled = enabled
        self.every_s = every_s
        self.stream = stream
        self.clock = clock
        self.count = 0
        self.lines = 0
        self._start = clock()
        self._last = self._start

    def update(self, n: int = 1) -> None:
        self.count += n
        if not self.enabled:
            return
        now = self.clock()
        if now - self._last >= self.every_s:
            self._last = now
            self._write(now)

    def close(self) -> None:
        if self.enabled and self.count:
            self._write(self.clock(), done=True)
        self.enabled = False

    def text(self, now: float, done: bool = False) -> str:
        elapsed = max(now - self._start, 1e-9)
        rate = self.count / elapsed
        if self.total:
            parts = [
                f"{self.count}/{self.total} {self.unit} ({100 * self.count / self.total:.0f} %)"
            ]
        else:
            parts = [f"{self.count} {self.unit}"]
        parts.append(f"{rate:.1f} {self.unit}/s")
        if done:
            parts.append(f"{elapsed:.0f} s")
        elif self.total and rate > 0:
            parts.append(f"about {max(self.total - self.count, 0) / rate:.0f} s left")
        return f"{self.desc}: " + ", ".join(parts)

    def _write(self, now: float, done: bool = False) -> None:
        stream = sys.stderr if self.stream is None else self.stream
        print(self.text(now, done), file=stream, flush=True)
        self.lines += 1

    def __enter__(self) -> ProgressLine:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
