"""Small copies of the camera's frames, for the session recording and the dashboard.

The camera thread hands each processed frame to a FrameTap (when the daemon has one): at most
`period_s` apart, the colour and depth are shrunk to `width` pixels wide (a copy: nothing keeps
the camera's own buffers) and kept with the frame's detections as a FrameView. The tap keeps the
last few views in one tuple that is replaced, never changed, so the daemon's loop and the
dashboard read it without a lock and the camera thread never waits for them.

JPEG encoding (`jpeg`, `depth_jpeg`) happens where the pictures are used: on the recording's
writer thread and the dashboard's thread, never on the control loop.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

DEPTH_MAX_M = 4.0  # the depth picture's colour scale: 0 (near) .. DEPTH_MAX_M (far)


@dataclass(frozen=True, slots=True)
class Box:
    """A detection in the full frame's pixels, with the ring's distance on the floor when it was
    placed (None: detected but not placed)."""

    x0: float
    y0: float
    x1: float
    y1: float
    score: float
    distance_m: float | None = None

    def as_list(self) -> list[float | None]:
        d = None if self.distance_m is None else round(self.distance_m, 3)
        return [
            round(self.x0, 1), round(self.y0, 1), round(self.x1, 1), round(self.y1, 1),
            round(self.score, 3), d,
        ]  # fmt: skip


@dataclass(frozen=True, slots=True)
class FrameView:
    """One processed frame, shrunk; `id` is its perception result's (camera_feed.Perceived)."""

    id: int
    stamp_s: float
    color: NDArray[np.uint8]  # (h, w, 3) BGR, `width` wide
    depth_m: NDArray[np.float32] | None  # (h, w) metres, 0 where unknown
    source_size: tuple[int, int]  # the full frame's (width, height): the boxes' pixels
    boxes: tuple[Box, ...]


def boxes_of(result: Any) -> tuple[Box, ...]:
    """The detections of a jetson.perception Result (placed rings with their distance first)."""
    out: list[Box] = []
    placed = set()
    for ring in getattr(result, "rings", ()) or ():
        d = ring.detection
        placed.add(id(d))
        out.append(Box(d.x0, d.y0, d.x1, d.y1, d.score, float(ring.distance_m)))
    for d in getattr(result, "detections", ()) or ():
        if id(d) not in placed:
            out.append(Box(d.x0, d.y0, d.x1, d.y1, d.score, None))
    return tuple(out)


def shrink(image: NDArray[Any], width: int, nearest: bool = False) -> NDArray[Any]:
    """A copy of `image` at most `width` pixels wide (aspect kept)."""
    import cv2

    h, w = image.shape[:2]
    if w <= width:
        return np.array(image, copy=True)
    size = (width, max(1, round(h * width / w)))
    return cv2.resize(image, size, interpolation=cv2.INTER_NEAREST if nearest else cv2.INTER_AREA)


def newest_view(views: Sequence[FrameView]) -> FrameView | None:
    """The newest of a tap's views (kept oldest first), None when it has none."""
    return views[-1] if views else None


def view_for(views: Sequence[FrameView], result_id: int) -> FrameView | None:
    """The view of perception result `result_id` among a tap's views, newest first; None when
    it is not (or no longer) among them."""
    for v in reversed(views):
        if v.id == result_id:
            return v
    return None


class FrameTap:
    """The camera thread's frames for the recording and the dashboard (see the module doc).

    offer() runs on the camera thread; views / get() / newest from any thread."""

    def __init__(self, period_s: float = 0.1, width: int = 320, keep: int = 6) -> None:
        self.period_s = period_s
        self.width = width
        self.keep = keep
        self.views: tuple[FrameView, ...] = ()
        self.offered = 0
        self.taken = 0
        self._last_stamp = -math.inf
        # Called (on the camera thread) with each view kept: the dashboard's process gets its
        # frames this way (jetson/dashboard/bridge.py). It must not wait; what it raises is
        # counted, never passed on to the camera thread.
        self.sink: Callable[[FrameView], object] | None = None
        self.sink_errors = 0

    @property
    def newest(self) -> FrameView | None:
        return newest_view(self.views)

    def get(self, result_id: int) -> FrameView | None:
        return view_for(self.views, result_id)

    def offer(self, result_id: int, stamp_s: float, frame: Any, result: Any) -> None:
        """A processed frame (jetson.perception.frame.Frame) and its pipeline Result; kept when
        period_s has passed since the last kept one."""
        self.offered += 1
        if stamp_s - self._last_stamp < self.period_s and stamp_s >= self._last_stamp:
            return
        color = getattr(frame, "color", None)
        if color is None:
            return
        self._last_stamp = stamp_s
        depth = getattr(frame, "depth_m", None)
        h, w = color.shape[:2]
        view = FrameView(
            result_id,
            stamp_s,
            shrink(color, self.width),
            None if depth is None else shrink(depth, self.width, nearest=True),
            (int(w), int(h)),
            boxes_of(result) if result is not None else (),
        )
        self.views = (*self.views[-(self.keep - 1) :], view)
        self.taken += 1
        if self.sink is not None:
            try:
                self.sink(view)
            except Exception:
                self.sink_errors += 1


def frame_bytes_for(width: int) -> int:
    """Room for a pickled FrameView `width` pixels wide (colour 3 bytes and depth 4 bytes a
    pixel, up to a square frame), with a margin for its boxes: the size of a shared-memory slot
    that carries one (jetson/slots.py)."""
    return 7 * width * width + 256 * 1024


def jpeg(image: NDArray[np.uint8], width: int | None = None, quality: int = 75) -> bytes:
    """BGR image -> JPEG bytes, shrunk to `width` first when given."""
    import cv2

    if width is not None:
        image = shrink(image, width)
    ok, data = cv2.imencode(".jpg", image, [int(cv2.IMWRITE_JPEG_QUALITY), int(quality)])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return bytes(data)


def depth_colours(depth_m: NDArray[np.floating]) -> NDArray[np.uint8]:
    """Depth in metres -> a BGR picture: near is warm, far is cool, unknown black."""
    import cv2

    d = np.nan_to_num(np.asarray(depth_m, dtype=np.float32), nan=0.0, posinf=0.0)
    scaled = np.clip(255.0 - d * (255.0 / DEPTH_MAX_M), 0, 255).astype(np.uint8)
    out = cv2.applyColorMap(scaled, cv2.COLORMAP_JET)
    out[d <= 0] = 0
    return out


def depth_jpeg(depth_m: NDArray[np.floating], width: int | None = None, quality: int = 70) -> bytes:
    if width is not None:
        depth_m = shrink(depth_m, width, nearest=True)
    return jpeg(depth_colours(depth_m), None, quality)


def b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def view_record(view: FrameView, width: int, quality: int = 70) -> dict[str, Any]:
    """A FrameView as a JSON record: JPEGs (base64) of the colour and the depth, the boxes in the
    full frame's pixels, and that frame's size."""
    return {
        "id": view.id,
        "stamp": view.stamp_s,
        "size": list(view.source_size),
        "jpeg": b64(jpeg(view.color, width, quality)),
        "depth": None if view.depth_m is None else b64(depth_jpeg(view.depth_m, width, quality)),
        "boxes": [b.as_list() for b in view.boxes],
    }
