"""Slots of shared memory between the daemon's process and its helpers' (the camera's, the
dashboard's): the newest payload of each kind, read without ever making the robot's side wait.

A slot is a fixed block of shared memory (allocated at start-up, never grown) with a sequence
number, a length and a lock. A writer never waits: put() tries the lock once and, when a reader
holds it at that moment, drops this write (the next one replaces it). A payload larger than the
slot is dropped and counted. A reader takes the lock to copy the payload out: waiting a little
(take(), a helper's side), or only when it is free at once (take(wait=False), the daemon's
thread, which keeps the value it read before). Slots are made before the helper's process
starts and passed to it as a Process argument.
"""

from __future__ import annotations

import pickle
import struct
from multiprocessing.context import SpawnContext
from typing import Any

HEADER = struct.Struct("<QQ")  # sequence number, payload length
READ_WAIT_S = 0.2


class Slot:
    """One block of shared memory holding the newest payload (see the module doc)."""

    def __init__(self, ctx: SpawnContext, size: int) -> None:
        self.size = size
        self._mem = ctx.RawArray("B", HEADER.size + size)
        self._lock = ctx.Lock()
        self.dropped_busy = 0  # writes dropped while a reader held the lock
        self.dropped_large = 0  # writes dropped for not fitting

    def __getstate__(self) -> dict[str, Any]:
        return {"size": self.size, "_mem": self._mem, "_lock": self._lock}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
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
            view = memoryview(self._mem).cast("B")
            seq = HEADER.unpack_from(view, 0)[0] + 1  # whichever process wrote last
            view[HEADER.size : HEADER.size + len(payload)] = payload
            HEADER.pack_into(view, 0, seq, len(payload))
        finally:
            self._lock.release()
        return True

    def take(self, after: int, wait: bool = True) -> tuple[int, bytes] | None:
        """The payload and its sequence number when newer than `after`, else None. With `wait`
        False, None also when another process holds the slot at this moment."""
        if not (self._lock.acquire(True, READ_WAIT_S) if wait else self._lock.acquire(False)):
            return None
        try:
            view = memoryview(self._mem).cast("B")
            seq, length = HEADER.unpack_from(view, 0)
            if seq == after or length == 0:
                return None
            return seq, bytes(view[HEADER.size : HEADER.size + length])
        finally:
            self._lock.release()


class Latest:
    """A reader's side of a slot: the newest payload, unpickled once (the same object until a
    newer one is written, so callers can compare by identity). `wait` False: never waits for a
    writer (the daemon's thread); the value read before stands meanwhile."""

    def __init__(self, slot: Slot, wait: bool = True) -> None:
        self._slot = slot
        self._wait = wait
        self._seq = 0
        self.value: Any = None

    @property
    def seq(self) -> int:
        return self._seq

    def get(self) -> Any:
        got = self._slot.take(self._seq, self._wait)
        if got is not None:
            self._seq, data = got
            self.value = pickle.loads(data)
        return self.value
