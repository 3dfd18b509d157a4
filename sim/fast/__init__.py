"""The batched training backend: thousands of training-fidelity matches stepped at once.

    from sim.fast import FastWorld
    world = FastWorld(WorldConfig(), n_matches=4096)
    world.reset(seeds=range(4096))
    events = world.step(linear, angular)            # (B, R) arrays: one control step everywhere

`world` (FastWorld) is the physics and the rules over arrays shaped (matches, robots, ...): one
numpy operation per rule for every match together, the contacts a compiled loop over the matches
(`kernels`, numba). `observe` builds every robot's observation (visibility, GPS, the spec's
frames); `matches` is the trainer's interface (VecMatches'); `view` shows one match as the
per-match World that scripted players and the renderer read. The field file, the rules
(sim.world.rules' array functions) and the observation spec are the PyBullet twin's: nothing here
is a second copy of them. PyBullet stays the reference.
"""

from sim.fast.world import FastEvents, FastWorld

__all__ = ["FastEvents", "FastWorld"]
