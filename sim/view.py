"""`pete-sim view`: pictures of a seeded field and of a scripted match."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sim.baselines.scripted import GreedyChaser
from sim.camera import render_camera
from sim.config import WorldConfig, world_preset
from sim.errors import ConfigError
from sim.render import save_gif, save_png, top_down
from sim.world.physics import World


def write_view(
    seed: int,
    out: Path,
    fidelity: str = "training",
    stride: int = 4,
    size: int = 480,
    seconds: float | None = None,
    gif: bool = True,
    camera: bool = True,
    world: str | None = None,
) -> list[Path]:
    """Write start.png (and camera.png, match.gif) under `out`; return the paths written.
    `world`: a sim.config.WORLD_PRESETS name (None: the ring race), e.g. the whole game's 2v2."""
    if stride < 1:
        raise ValueError(f"--stride must be at least 1, got {stride}")
    if not 64 <= size <= 2048:
        raise ValueError(f"--size must be within 64..2048, got {size}")
    if seconds is not None and seconds <= 0:
        raise ValueError(f"--seconds must be positive, got {seconds}")
    jitter = {"start_jitter_m": 0.05, "start_jitter_deg": 5.0}
    if world is None:
        cfg = WorldConfig(fidelity=fidelity, **jitter)  # type: ignore[arg-type]
    else:
        try:
            cfg = world_preset(world, fidelity=fidelity, **jitter)
        except ConfigError as e:
            raise ValueError(str(e)) from e
    written = []
    with World(cfg) as world:
        world.reset(np.random.default_rng(seed))
        written.append(save_png(top_down(world, size), out / "start.png"))
        if camera:
            frame = render_camera(world, 0, world.robots[0].config.camera.scaled(320, 240))
            written.append(save_png(frame.rgb, out / "camera.png"))
        if gif:
            bots = [GreedyChaser(i) for i in range(len(world.robots))]
            frames = [top_down(world, size)]
            limit = world.match_length_s if seconds is None else min(seconds, world.match_length_s)
            while not world.over and world.time_s < limit - 1e-9:
                world.step([b.act(world) for b in bots])
                if world.steps % stride == 0 or world.over:
                    frames.append(top_down(world, size))
            fps = world.config.control_hz / stride * 3  # three times real time
            written.append(save_gif(frames, out / "match.gif", fps=fps))
    return written
