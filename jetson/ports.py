"""Find the V5 Brain's USB serial ports, as pros-cli does.

A V5 Brain enumerates two CDC ACM interfaces (USB VID 0x2888): the "system" port (uploads, the PROS
terminal's control traffic) and the "user" port, which carries the program's stdin/stdout and is the
one the Jetson talks on.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

VEX_VID = 0x2888


class PortInfo(Protocol):
    """The subset of pyserial's ListPortInfo that we read."""

    device: str
    vid: int | None
    description: str | None
    location: str | None


@dataclass(frozen=True)
class V5Port:
    device: str
    kind: str  # "user" or "system"
    description: str


def _kind(port: PortInfo) -> str | None:
    desc = (port.description or "").lower()
    loc = port.location or ""
    if "user" in desc or loc.endswith("2"):
        return "user"
    if any(w in desc for w in ("system", "communications")) or loc.endswith("0"):
        return "system"
    return None


def classify_v5_ports(ports: Iterable[PortInfo]) -> list[V5Port]:
    """V5 ports among `ports`, user port first. With exactly two unlabelled V5 ports the
    higher-numbered one is the user port (pros-cli's fallback; usually /dev/ttyACM1)."""
    v5 = [p for p in ports if p.vid == VEX_VID]
    kinds = {p.device: _kind(p) for p in v5}
    if len(v5) == 2 and None in kinds.values():
        low, high = sorted(v5, key=lambda p: p.device)
        kinds = {low.device: "system", high.device: "user"}
    found = [V5Port(p.device, kinds[p.device] or "unknown", p.description or "") for p in v5]
    order = {"user": 0, "unknown": 1, "system": 2}
    return sorted(found, key=lambda p: (order[p.kind], p.device))


def list_v5_ports() -> list[V5Port]:
    """The V5 ports on this machine (needs pyserial, part of the `jetson` extra)."""
    try:
        from serial.tools import list_ports
    except ImportError as exc:
        raise RuntimeError("pyserial is not installed: pip install 'pacman-pete[jetson]'") from exc
    return classify_v5_ports(list_ports.comports())
