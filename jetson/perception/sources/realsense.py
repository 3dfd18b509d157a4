"""Intel RealSense D435 colour + depth, live or from a .bag recording, through pyrealsense2.

pyrealsense2 is the optional extra `pacman-pete[realsense]` (PyPI wheels are x86-64 only; on a
Jetson, librealsense is built from source with its Python bindings) and is imported only when a
RealSense source is opened. Depth is aligned to the colour camera (rs.align), so depth pixel
(u, v) is colour pixel (u, v), and the intrinsics are the colour stream's.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from types import ModuleType
from typing import Any

import cv2
import numpy as np

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError
from jetson.perception.frame import Frame
from jetson.perception.sources.base import FrameSource

INSTALL_HINT = (
    "pyrealsense2 is not installed: pip install 'pacman-pete[realsense]' on x86-64; on a Jetson, "
    "build librealsense from source with -DBUILD_PYTHON_BINDINGS=ON"
)


def import_pyrealsense2() -> ModuleType:
    try:
        import pyrealsense2
    except ImportError as exc:
        raise SourceError(INSTALL_HINT) from exc
    return pyrealsense2


class RealSenseSource(FrameSource):
    """A live camera (bag=None) or a .bag file played back as fast as it is read."""

    def __init__(
        self,
        serial: str | None = None,
        *,
        bag: Path | str | None = None,
        width: int = 640,
        height: int = 480,
        fps: int = 30,
        timeout_s: float = 5.0,
        rs: ModuleType | None = None,
    ) -> None:
        self._rs = rs if rs is not None else import_pyrealsense2()
        rs = self._rs
        self._bag = Path(bag) if bag is not None else None
        self._timeout_ms = int(timeout_s * 1000)
        if self._bag is not None:
            if not self._bag.is_file():
                raise SourceError(f"RealSense recording {self._bag} does not exist")
            self.description = f"RealSense recording {self._bag}"
        else:
            devices = rs.context().query_devices()
            if len(devices) == 0:
                raise SourceError(
                    "no RealSense camera connected (is it on a USB 3 port? `rs-enumerate-devices` "
                    "lists what librealsense sees)"
                )
            self.description = f"RealSense {serial or 'camera'}"
        config = rs.config()
        if self._bag is not None:
            config.enable_device_from_file(str(self._bag), repeat_playback=False)
        else:
            if serial:
                config.enable_device(serial)
            config.enable_stream(rs.stream.color, width, height, rs.format.bgr8, fps)
            config.enable_stream(rs.stream.depth, width, height, rs.format.z16, fps)
        self._pipeline = rs.pipeline()
        try:
            profile = self._pipeline.start(config)
        except RuntimeError as exc:
            raise SourceError(f"cannot start {self.description}: {exc}") from exc
        device = profile.get_device()
        if self._bag is not None:
            device.as_playback().set_real_time(False)  # every frame, as fast as we read
        self._depth_scale = float(device.first_depth_sensor().get_depth_scale())
        self._align = rs.align(rs.stream.color)
        vsp = profile.get_stream(rs.stream.color).as_video_stream_profile()
        self.intrinsics = intrinsics_from_rs(vsp.get_intrinsics())
        self._started = True

    def read(self) -> Frame | None:
        if not self._started:
            return None
        rs = self._rs
        while True:
            if self._bag is not None:
                ok, frames = self._pipeline.try_wait_for_frames(self._timeout_ms)
                if not ok:
                    return None  # the end of the recording
            else:
                try:
                    frames = self._pipeline.wait_for_frames(self._timeout_ms)
                except RuntimeError as exc:
                    raise SourceError(
                        f"{self.description} sent no frame in {self._timeout_ms} ms "
                        f"(unplugged?): {exc}"
                    ) from exc
            aligned = self._align.process(frames)
            color_frame = aligned.get_color_frame()
            if not color_frame:
                continue  # a depth-only frameset at the start of a bag
            depth_frame = aligned.get_depth_frame()
            color = _to_bgr(np.asanyarray(color_frame.get_data()), color_frame, rs)
            depth = None
            if depth_frame:
                raw = np.asanyarray(depth_frame.get_data())
                depth = raw.astype(np.float32) * np.float32(self._depth_scale)
            return Frame(
                color,
                depth,
                self.intrinsics,
                float(color_frame.get_timestamp()) / 1000.0,
                int(color_frame.get_frame_number()),
            )

    def close(self) -> None:
        if self._started:
            self._started = False
            # An unplugged camera has already stopped; there is nothing left to release.
            with contextlib.suppress(RuntimeError):
                self._pipeline.stop()


def intrinsics_from_rs(intr: Any) -> Intrinsics:
    """librealsense's rs2_intrinsics (ppx, ppy, coeffs) as ours."""
    coeffs = tuple(float(c) for c in intr.coeffs)
    return Intrinsics(
        int(intr.width), int(intr.height), float(intr.fx), float(intr.fy),
        float(intr.ppx), float(intr.ppy), coeffs if len(coeffs) == 5 else (0.0,) * 5,
    )  # fmt: skip


def _to_bgr(data: np.ndarray, frame: Any, rs: ModuleType) -> np.ndarray:
    fmt = frame.get_profile().format()
    if fmt == rs.format.bgr8:
        return np.ascontiguousarray(data)
    if fmt == rs.format.rgb8:
        return cv2.cvtColor(data, cv2.COLOR_RGB2BGR)
    if fmt == rs.format.rgba8:
        return cv2.cvtColor(data, cv2.COLOR_RGBA2BGR)
    if fmt == rs.format.bgra8:
        return cv2.cvtColor(data, cv2.COLOR_BGRA2BGR)
    raise SourceError(f"RealSense colour format {fmt} is not supported (use bgr8 or rgb8)")
