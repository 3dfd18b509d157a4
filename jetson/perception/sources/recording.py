"""Our own recording format on disk, and the recorder that writes it.

    DIR/recording.json   {"format": "pete-recording", "version": 1,
                          "intrinsics": {...}, "depth_unit_m": 0.001, "source": "..."}
    DIR/frames.jsonl     one line per frame, appended as frames arrive:
                          {"index": 0, "timestamp_s": 12.345, "color": "color/000000.png",
                           "depth": "depth/000000.png"}          ("depth": null when none)
    DIR/color/NNNNNN.png colour, 8-bit BGR PNG (lossless, so detectors see what the camera saw)
    DIR/depth/NNNNNN.png depth aligned to colour, 16-bit PNG in millimetres, 0 = no reading

frames.jsonl is flushed per frame, so a recording cut short by a crash or a power cut still
plays back up to its last whole frame.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Any

import cv2

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError
from jetson.perception.frame import DEPTH_UNIT_M, Frame, depth_from_mm, depth_to_mm
from jetson.perception.sources.base import FrameSource

RECORDING_FORMAT = "pete-recording"
RECORDING_VERSION = 1
HEADER = "recording.json"
INDEX = "frames.jsonl"


def is_recording(path: Path) -> bool:
    return (Path(path) / HEADER).is_file()


class Recorder:
    """Writes frames into a recording folder (which must not already hold one)."""

    def __init__(self, root: Path | str, source: str = "") -> None:
        self.root = Path(root)
        if is_recording(self.root):
            raise SourceError(f"{self.root} already holds a recording; choose another folder")
        (self.root / "color").mkdir(parents=True, exist_ok=True)
        (self.root / "depth").mkdir(parents=True, exist_ok=True)
        self.source = source
        self.count = 0
        self._intrinsics: Intrinsics | None = None
        self._index: IO[str] | None = None

    def write(self, frame: Frame) -> None:
        if self._intrinsics is None:
            self._intrinsics = frame.intrinsics
            header = {
                "format": RECORDING_FORMAT,
                "version": RECORDING_VERSION,
                "intrinsics": frame.intrinsics.to_dict(),
                "depth_unit_m": DEPTH_UNIT_M,
                "source": self.source,
            }
            (self.root / HEADER).write_text(json.dumps(header, indent=2) + "\n")
            self._index = (self.root / INDEX).open("a")
        elif frame.intrinsics != self._intrinsics:
            raise SourceError("the camera's intrinsics changed mid-recording; start a new one")
        name = f"{self.count:06d}.png"
        if not cv2.imwrite(str(self.root / "color" / name), frame.color):
            raise SourceError(f"cannot write {self.root / 'color' / name}")
        entry: dict[str, Any] = {
            "index": frame.index,
            "timestamp_s": frame.timestamp_s,
            "color": f"color/{name}",
            "depth": None,
        }
        if frame.depth_m is not None:
            cv2.imwrite(str(self.root / "depth" / name), depth_to_mm(frame.depth_m))
            entry["depth"] = f"depth/{name}"
        assert self._index is not None
        self._index.write(json.dumps(entry) + "\n")
        self._index.flush()
        self.count += 1

    def close(self) -> None:
        if self._index is not None:
            self._index.close()
            self._index = None

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RecordingSource(FrameSource):
    def __init__(self, root: Path | str) -> None:
        self.root = Path(root)
        self.description = f"recording {self.root}"
        header_path = self.root / HEADER
        if not self.root.is_dir():
            raise SourceError(f"recording folder {self.root} does not exist")
        if not header_path.is_file():
            raise SourceError(f"{self.root} is not a recording (no {HEADER})")
        try:
            header = json.loads(header_path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise SourceError(f"{header_path} cannot be read: {exc}") from exc
        if header.get("format") != RECORDING_FORMAT or header.get("version") != RECORDING_VERSION:
            raise SourceError(f"{header_path} is not a {RECORDING_FORMAT} v{RECORDING_VERSION}")
        if header.get("depth_unit_m", DEPTH_UNIT_M) != DEPTH_UNIT_M:
            raise SourceError(f"{header_path}: only depth_unit_m {DEPTH_UNIT_M} is supported")
        self.intrinsics = Intrinsics.from_dict(header["intrinsics"])
        self.entries = self._entries()
        self._next = 0

    def _entries(self) -> list[dict[str, Any]]:
        path = self.root / INDEX
        if not path.is_file():
            return []
        out = []
        lines = path.read_text().splitlines()
        for n, line in enumerate(lines, start=1):
            if not line.strip():
                continue
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError as exc:
                if n == len(lines):
                    break  # a last line cut short by a crash: play what came before
                raise SourceError(f"{path}:{n}: not JSON: {exc}") from exc
        return out

    def __len__(self) -> int:
        return len(self.entries)

    def read(self) -> Frame | None:
        if self._next >= len(self.entries):
            return None
        e = self.entries[self._next]
        self._next += 1
        color_path = self.root / e["color"]
        color = cv2.imread(str(color_path), cv2.IMREAD_COLOR)
        if color is None:
            raise SourceError(f"{color_path} is missing or not an image")
        depth = None
        if e.get("depth"):
            raw = cv2.imread(str(self.root / e["depth"]), cv2.IMREAD_UNCHANGED)
            if raw is None:
                raise SourceError(f"{self.root / e['depth']} is missing or not an image")
            depth = depth_from_mm(raw)
        return Frame(color, depth, self.intrinsics, float(e["timestamp_s"]), int(e["index"]))
