"""Where a match starts: each robot's pose and the rings on the floor, drawn from the match's
generator. World.reset and the batched backend (sim.fast) both draw through it, so the same
seed starts the same match in both. No PyBullet here."""

from __future__ import annotations

import numpy as np

from jetson.autonomy.geometry import wrap_heading
from sim.config import WorldConfig
from sim.field import FieldSpec


def robot_starts(
    field: FieldSpec,
    config: WorldConfig,
    lineup: list[tuple[str, str]],
    rng: np.random.Generator,
) -> list[tuple[float, float, float]]:
    """Each robot's (x, y, heading) at the start, in lineup order: its field start, jittered by
    start_jitter_m and start_jitter_deg (x, y, heading drawn robot by robot)."""
    poses = []
    for alliance, name in lineup:
        start = field.start(alliance, name)  # type: ignore[arg-type]
        jit = config.start_jitter_m
        x = start.position[0] + (rng.uniform(-jit, jit) if jit > 0 else 0.0)
        y = start.position[1] + (rng.uniform(-jit, jit) if jit > 0 else 0.0)
        hj = config.start_jitter_deg
        heading = float(wrap_heading(start.heading + (rng.uniform(-hj, hj) if hj > 0 else 0)))
        poses.append((float(x), float(y), heading))
    return poses


def floor_rings(field: FieldSpec, config: WorldConfig, rng: np.random.Generator) -> np.ndarray:
    """The rings on the floor at the start (N, 2): the field's layout jittered by ring_jitter_m
    (kept inside the walls), then the match loads when the match has them."""
    xy = [field.ring_positions.copy()]
    if config.ring_jitter_m > 0:
        xy[0] += rng.uniform(-config.ring_jitter_m, config.ring_jitter_m, xy[0].shape)
        np.clip(xy[0], -field.half + field.ring.radius, field.half - field.ring.radius, out=xy[0])
    if config.match_loads:
        spots = field.match_load_spots[: field.ring.match_loads_per_alliance]
        xy += [spots, -spots]
    return np.concatenate(xy) if xy else np.zeros((0, 2))
