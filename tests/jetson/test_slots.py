"""The shared-memory slots between the daemon's process and its helpers' (jetson/slots.py): the
newest payload is kept and read once, a payload too large is dropped, and neither side ever
waits for the other."""

from __future__ import annotations

import multiprocessing
import pickle
import time
from typing import Any

import pytest

from jetson.slots import Latest, Slot


@pytest.fixture
def ctx() -> Any:
    return multiprocessing.get_context("spawn")


def test_a_slot_keeps_the_newest_and_is_read_once(ctx: Any) -> None:
    slot = Slot(ctx, 64)
    assert slot.take(0) is None
    assert slot.put(b"first") and slot.put(b"second")
    seq, data = slot.take(0)
    assert data == b"second" and seq == 2
    assert slot.take(seq) is None
    assert not slot.put(b"x" * 65) and slot.dropped_large == 1
    assert slot.take(seq) is None  # the payload that did not fit changed nothing


def test_a_slot_held_by_one_side_never_makes_the_other_wait(ctx: Any) -> None:
    slot = Slot(ctx, 64)
    assert slot.put(pickle.dumps("before"))
    slot._lock.acquire()  # the other process in the middle of a read or a write
    try:
        t0 = time.perf_counter()
        written = [slot.put(b"snapshot") for _ in range(1000)]
        reader = Latest(slot, wait=False)
        read = [reader.get() for _ in range(1000)]
        spent = time.perf_counter() - t0
    finally:
        slot._lock.release()
    assert not any(written) and slot.dropped_busy == 1000
    assert read == [None] * 1000  # nothing read yet: the reader did not wait either
    assert spent < 0.1, f"2000 refused writes and reads took {spent:.3f} s"
    assert reader.get() == "before"
    assert slot.put(b"after") and slot.take(0)[1] == b"after"


def test_the_sequence_follows_whichever_process_wrote_last(ctx: Any) -> None:
    """A slot written from two processes (the camera's and, in tests, the daemon's) still counts
    up: a reader never takes an older payload for a newer one."""
    slot = Slot(ctx, 64)
    assert slot.put(b"one")
    child = ctx.Process(target=_put_two, args=(slot,))
    child.start()
    child.join(30)
    assert child.exitcode == 0
    seq, data = slot.take(0)
    assert (seq, data) == (3, b"three")
    reader = Latest(slot)
    assert slot.put(pickle.dumps("four")) and reader.get() == "four" and reader.seq == 4


def _put_two(slot: Slot) -> None:
    slot.put(b"two")
    slot.put(b"three")
