"""What crosses between the daemon's process and the dashboard's: slots of shared memory.

The dashboard's server runs in its own process (jetson/dashboard/process.py) so that a browser
never takes the daemon's interpreter (Python runs one thread at a time per process) or its CPU
share: the dashboard's process runs below the control loop. The two processes share:

- a snapshot slot: the daemon's thread writes its newest snapshot (Observer.take(), pickled);
- a frame slot: the camera thread writes each frame view the FrameTap keeps (pickled);
- a stats slot: the dashboard's process writes what it has sent, for tests and benchmarks;
- a flag: set by the dashboard when it wants a snapshot, cleared by the daemon when it writes one.

A slot is a fixed block of shared memory (allocated at start-up, never grown) with a sequence
number, a length and a lock. The robot's side never waits: put() tries the lock once and, when
the dashboard is reading at that moment, drops this write (the next one replaces it). A payload
larger than the slot is dropped and counted. The dashboard's side takes the lock to read: a
reader that stalls holding it costs the robot nothing but dropped snapshots.
"""

from __future__ import annotations

import pickle
import struct
from multiprocessing.context import SpawnContext
from typing import Any

HEADER = struct.Struct("<QQ")  # sequence number, payload length
READ_WAIT_S = 0.2


class Slot:
    """One block of shared memory holding the newest payload (see the module doc). Made in the
    daemon's process; passed to the dashboard's process as a Process argument."""

    def __init__(self, ctx: SpawnContext, size: int) -> None:
        self.size = size
        self._mem = ctx.RawArray("B", HEADER.size + size)
        self._lock = ctx.Lock()
        self._seq = 0
        self.dropped_busy = 0  # writes dropped while the reader held the lock
        self.dropped_large = 0  # writes dropped for not fitting

    def __getstate__(self) -> dict[str, Any]:
        return {"size": self.size, "_mem": self._mem, "_lock": self._lock}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._seq = 0
        self.dropped_busy = self.dropped_large = 0

    def put(self, payload: bytes) -> bool:
        """Write `payload` if the slot is free now; never waits. True when written."""
        if len(payload) > self.size:
            self.dropped_large += 1
            return False
        if not self._lock.acquire(False):
            self.dropped_busy += 1
            return False
        try:
            self._seq += 1
            view = memoryview(self._mem).cast("B")
            view[HEADER.size : HEADER.size + len(payload)] = payload
            HEADER.pack_into(view, 0, self._seq, len(payload))
        finally:
            self._lock.release()
        return True

    def take(self, after: int) -> tuple[int, bytes] | None:
        """The payload and its sequence number when newer than `after`, else None."""
        if not self._lock.acquire(True, READ_WAIT_S):
            return None
        try:
            view = memoryview(self._mem).cast("B")
            seq, length = HEADER.unpack_from(view, 0)
            if seq == after or length == 0:
                return None
            return seq, bytes(view[HEADER.size : HEADER.size + length])
        finally:
            self._lock.release()


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
    """The slots and the flag of one dashboard. `frame_bytes`: room for one pickled FrameView."""

    def __init__(self, ctx: SpawnContext, snapshot_bytes: int, frame_bytes: int) -> None:
        self.snapshots = Slot(ctx, snapshot_bytes)
        self.frames = Slot(ctx, frame_bytes)
        self.stats = Slot(ctx, 64 * 1024)
        self.wanted = Flag(ctx)

    # --- the daemon's side ---------------------------------------------------------------

    def post_snapshot(self, raw: dict[str, Any]) -> bool:
        return self.snapshots.put(pickle.dumps(raw, protocol=pickle.HIGHEST_PROTOCOL))

    def post_frame(self, view: Any) -> bool:
        return self.frames.put(pickle.dumps(view, protocol=pickle.HIGHEST_PROTOCOL))


def frame_bytes_for(width: int) -> int:
    """Room for a pickled FrameView `width` pixels wide (colour 3 bytes and depth 4 bytes a
    pixel, up to a square frame), with a margin for its boxes."""
    return 7 * width * width + 256 * 1024


class Latest:
    """The dashboard's side of a slot: the newest payload, unpickled once (the same object until
    a newer one is written, so callers can compare by identity)."""

    def __init__(self, slot: Slot) -> None:
        self._slot = slot
        self._seq = 0
        self.value: Any = None

    def get(self) -> Any:
        got = self._slot.take(self._seq)
        if got is not None:
            self._seq, data = got
            self.value = pickle.loads(data)
        return self.value
