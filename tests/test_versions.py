"""Every place that states the software version says the same thing (Hello carries it)."""

from __future__ import annotations

import importlib.metadata
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_brain_version_matches_the_python_distribution() -> None:
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    header = (ROOT / "brain" / "include" / "pete" / "core" / "version.hpp").read_text()
    match = re.search(r'kSoftwareVersion\[\] = "([^"]+)"', header)
    assert match, "version.hpp no longer declares kSoftwareVersion"
    assert match.group(1) == declared
    assert importlib.metadata.version("pacman-pete") == declared
