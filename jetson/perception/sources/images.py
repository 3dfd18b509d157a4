"""Plain images and videos as frames: no depth unless a dataset folder has a depth/ beside them.

Useful for running the detector on labelled photos or a phone video; without depth the rings
are detected but not placed (unless the localiser's floor fallback is on).
"""

from __future__ import annotations

from pathlib import Path

import cv2

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError
from jetson.perception.dataset import IMAGE_SUFFIXES
from jetson.perception.frame import Frame, depth_from_mm
from jetson.perception.sources.base import FrameSource

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm")


class ImageFolderSource(FrameSource):
    """Images in a folder (or its images/ subfolder, as in a dataset), in name order.

    Depth comes from DIR/depth/NAME.png (16-bit mm) when present. Intrinsics: the given ones,
    scaled to each image's size, or the default D435 calibration scaled likewise.
    """

    def __init__(
        self, folder: Path | str, intrinsics: Intrinsics | None = None, fps: float = 30.0
    ) -> None:
        root = Path(folder)
        if not root.is_dir():
            raise SourceError(f"image folder {root} does not exist")
        images = root / "images" if (root / "images").is_dir() else root
        self.files = sorted(p for p in images.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self.files:
            raise SourceError(f"{images} holds no images ({', '.join(IMAGE_SUFFIXES)})")
        self.depth_dir = root / "depth" if images != root else None
        self.intrinsics = intrinsics or Intrinsics()
        self.fps = fps
        self.description = f"images in {images}"
        self._next = 0

    def __len__(self) -> int:
        return len(self.files)

    def read(self) -> Frame | None:
        if self._next >= len(self.files):
            return None
        path = self.files[self._next]
        index = self._next
        self._next += 1
        color = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if color is None:
            raise SourceError(f"{path} is not a readable image")
        h, w = color.shape[:2]
        intr = self.intrinsics
        if (intr.width, intr.height) != (w, h):
            intr = intr.scaled(w, h)
        depth = None
        if self.depth_dir is not None and (self.depth_dir / f"{path.stem}.png").is_file():
            raw = cv2.imread(str(self.depth_dir / f"{path.stem}.png"), cv2.IMREAD_UNCHANGED)
            if raw is not None and raw.shape == (h, w):
                depth = depth_from_mm(raw)
        return Frame(color, depth, intr, index / self.fps, index)


class VideoSource(FrameSource):
    def __init__(self, path: Path | str, intrinsics: Intrinsics | None = None) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise SourceError(f"video {self.path} does not exist")
        self._cap = cv2.VideoCapture(str(self.path))
        if not self._cap.isOpened():
            raise SourceError(f"{self.path} cannot be opened as a video")
        self.fps = self._cap.get(cv2.CAP_PROP_FPS) or 30.0
        self.intrinsics = intrinsics or Intrinsics()
        self.description = f"video {self.path}"
        self._index = 0

    def read(self) -> Frame | None:
        ok, color = self._cap.read()
        if not ok:
            return None
        h, w = color.shape[:2]
        intr = self.intrinsics
        if (intr.width, intr.height) != (w, h):
            intr = intr.scaled(w, h)
        frame = Frame(color, None, intr, self._index / self.fps, self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        self._cap.release()
