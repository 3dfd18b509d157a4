"""Camera sources behind one interface (base.FrameSource), and open_source to pick one.

realsense[:SERIAL]        a live RealSense camera (needs pyrealsense2)
PATH.bag                  a RealSense recording
DIR with recording.json   our own recording (recording.py)
unix:PATH | tcp:HOST:PORT a frame stream from another process (stream.py)
synthetic[:FPS]           rings on a floor, rendered, at FPS (30) a second (synthetic.py)
DIR of images             plain images (a dataset folder's depth/ is used when present)
PATH.mp4 (.avi, ...)      a video file
"""

from __future__ import annotations

from pathlib import Path

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError
from jetson.perception.sources.base import FrameSource

__all__ = ["FrameSource", "open_source"]


def open_source(
    spec: str, intrinsics: Intrinsics | None = None, connect_timeout_s: float = 5.0
) -> FrameSource:
    """Open the source `spec` names (see the module's doc); a clear SourceError if it can't.

    `intrinsics` is used for sources that do not carry their own (images, videos).
    """
    if spec == "realsense" or spec.startswith("realsense:"):
        from jetson.perception.sources.realsense import RealSenseSource

        serial = spec.partition(":")[2] or None
        return RealSenseSource(serial)
    if spec == "synthetic" or spec.startswith("synthetic:"):
        from jetson.perception.sources.synthetic import DEFAULT_FPS, SyntheticSource

        rate = spec.partition(":")[2]
        try:
            fps = float(rate) if rate else DEFAULT_FPS
            return SyntheticSource(fps, intrinsics)
        except ValueError as exc:
            raise SourceError(f"source {spec}: {exc}") from exc
    if spec.startswith(("unix:", "tcp:")):
        from jetson.perception.sources.stream import StreamSource

        return StreamSource(spec, connect_timeout_s=connect_timeout_s)
    path = Path(spec)
    if path.suffix.lower() == ".bag":
        from jetson.perception.sources.realsense import RealSenseSource

        return RealSenseSource(bag=path)
    if not path.exists():
        raise SourceError(
            f"source {spec} does not exist (give realsense, a .bag, a recording or image "
            "folder, a video, unix:/path / tcp:host:port for a frame stream, or synthetic)"
        )
    from jetson.perception.sources.images import VIDEO_SUFFIXES, ImageFolderSource, VideoSource
    from jetson.perception.sources.recording import RecordingSource, is_recording

    if path.is_dir():
        if is_recording(path):
            return RecordingSource(path)
        return ImageFolderSource(path, intrinsics)
    if path.suffix.lower() in VIDEO_SUFFIXES:
        return VideoSource(path, intrinsics)
    raise SourceError(f"{spec}: not a folder, .bag or video ({', '.join(VIDEO_SUFFIXES)})")
