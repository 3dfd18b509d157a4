"""What crosses between the daemon's process and the dashboard's: slots of shared memory.

The dashboard's server runs in its own process (jetson/dashboard/process.py) so that a browser
never takes the daemon's interpreter (Python runs one thread at a time per process) or its CPU
share: the dashboard's process runs below the control loop. The two processes share:

- a snapshot slot: the daemon's thread writes its newest snapshot (Observer.take(), pickled);
- a frame slot: each frame view the camera keeps (pickled), written by the daemon's camera
  thread through its FrameTap, or by the camera's own process (jetson/camera_process.py);
- a stats slot: the dashboard's process writes what it has sent, for tests and benchmarks;
- a flag: set by the dashboard when it wants a snapshot, cleared by the daemon when it writes one.

The slots are jetson/slots.py's: the robot's side never waits (a write that finds the dashboard
reading is dropped; the next one replaces it), so a reader that stalls costs the robot nothing
but dropped snapshots.
"""

from __future__ import annotations

import pickle
from multiprocessing.context import SpawnContext
from typing import Any

from jetson.slots import Slot


class Flag:
    """One byte both processes see (the dashboard wants a snapshot)."""

    def __init__(self, ctx: SpawnContext) -> None:
        self._value = ctx.RawValue("b", 0)

    def set(self) -> None:
        self._value.value = 1

    def take(self) -> bool:
        """True (and cleared) when set."""
        if self._value.value:
            self._value.value = 0
            return True
        return False


class Bridge:
    """The slots and the flag of one dashboard. `frame_bytes`: room for one pickled FrameView;
    `frames`: a frame slot someone else writes (a camera in its own process), instead of one of
    the bridge's own."""

    def __init__(
        self, ctx: SpawnContext, snapshot_bytes: int, frame_bytes: int, frames: Slot | None = None
    ) -> None:
        self.snapshots = Slot(ctx, snapshot_bytes)
        self.frames = frames if frames is not None else Slot(ctx, frame_bytes)
        self.stats = Slot(ctx, 64 * 1024)
        self.wanted = Flag(ctx)

    # --- the daemon's side ---------------------------------------------------------------

    def post_snapshot(self, raw: dict[str, Any]) -> bool:
        return self.snapshots.put(pickle.dumps(raw, protocol=pickle.HIGHEST_PROTOCOL))

    def post_frame(self, view: Any) -> bool:
        return self.frames.put(pickle.dumps(view, protocol=pickle.HIGHEST_PROTOCOL))
