"""What the Jetson side needs from Python 3.11 that Python 3.10 (JetPack 6) lacks, in one place.

protocol/ and jetson/ run on Python 3.10 and newer (`make check` runs vermin over them); the
simulator needs 3.11. Import `tomllib` and `StrEnum` from here, never from the standard library.
"""

from __future__ import annotations

import sys
from enum import Enum

if sys.version_info >= (3, 11):
    import tomllib  # novm
else:  # pragma: no cover - Python 3.10: the `tomli` dependency, the same parser under its own name
    import tomli as tomllib

__all__ = ["StrEnum", "tomllib"]


class StrEnum(str, Enum):
    """An Enum whose members are their string values, as enum.StrEnum (3.11) is: equal to, hashed
    as, printed and formatted as the value (str(LinkState.UP) == f"{LinkState.UP}" == "up")."""

    def __str__(self) -> str:
        return str(self.value)

    def __format__(self, format_spec: str) -> str:
        return format(str(self.value), format_spec)
