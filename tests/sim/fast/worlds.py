"""The world the fast backend's tests play: the 2v2 ring race with the start jitter training
uses (robots turned up to 45 degrees, rings moved up to 3 cm)."""

from __future__ import annotations

from sim.config import WorldConfig

RING_RACE_2V2 = WorldConfig(
    red=("24in", "15in"),
    blue=("24in", "15in"),
    start_jitter_m=0.1,
    start_jitter_deg=45.0,
    ring_jitter_m=0.03,
)
