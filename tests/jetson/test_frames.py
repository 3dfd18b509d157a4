"""The camera's frame copies (jetson/frames.py): FrameTap keeps one view a period, the newest few;
RemoteTap (jetson/camera_process.py) reads the views a camera in its own process hands on through
a shared-memory slot and finds them as FrameTap does (one lookup, jetson.frames.view_for)."""

from __future__ import annotations

import multiprocessing
import pickle
from types import SimpleNamespace

import numpy as np

from jetson.camera_process import RemoteTap
from jetson.frames import FrameTap, FrameView, frame_bytes_for, newest_view, view_for
from jetson.slots import Slot


def frame() -> SimpleNamespace:
    color = np.zeros((48, 64, 3), np.uint8)
    return SimpleNamespace(color=color, depth_m=np.ones((48, 64), np.float32))


def tap_with_views(n: int, keep: int = 3) -> FrameTap:
    tap = FrameTap(period_s=0.1, width=32, keep=keep)
    for i in range(n):
        tap.offer(10 + i, 0.25 * i, frame(), None)
    return tap


def test_the_tap_keeps_one_view_a_period_and_the_newest_few() -> None:
    tap = FrameTap(period_s=0.1, width=32, keep=3)
    assert tap.newest is None and tap.get(1) is None
    tap.offer(1, 0.0, frame(), None)
    tap.offer(2, 0.05, frame(), None)  # within the period: not kept
    assert [v.id for v in tap.views] == [1] and tap.offered == 2 and tap.taken == 1
    assert tap.views[0].color.shape == (24, 32, 3) and tap.views[0].source_size == (64, 48)
    for i in range(3, 7):
        tap.offer(i, 0.25 * (i - 2), frame(), None)
    assert [v.id for v in tap.views] == [4, 5, 6]
    assert tap.newest is tap.views[-1] and tap.get(5) is tap.views[1]
    assert tap.get(1) is None  # no longer kept


def test_the_lookups() -> None:
    views = tap_with_views(4, keep=4).views
    assert newest_view(views) is views[-1] and newest_view(()) is None
    assert view_for(views, 12) is views[2] and view_for(views, 99) is None
    # Two views of one result (a result offered twice): the newer one.
    twice = (*views, FrameView(12, 9.0, views[0].color, None, (64, 48), ()))
    assert view_for(twice, 12) is twice[-1]


def test_the_remote_tap_finds_views_as_the_tap_does() -> None:
    slot = Slot(multiprocessing.get_context("spawn"), frame_bytes_for(32))
    remote = RemoteTap(slot, period_s=0.1, width=32, keep=3)
    assert remote.newest is None and remote.views == ()
    local = tap_with_views(0)
    local.sink = lambda view: slot.put(pickle.dumps(view))
    for i in range(5):
        local.offer(20 + i, 0.25 * i, frame(), None)
        assert remote.newest is not None and remote.newest.id == 20 + i  # read as it comes
    assert [v.id for v in remote.views] == [v.id for v in local.views] == [22, 23, 24]
    got, kept = remote.get(23), local.get(23)
    assert got is not None and kept is not None and got.stamp_s == kept.stamp_s
    assert remote.get(20) is None and local.get(20) is None
