"""Ring dataset folders: YOLO format, optionally with depth and ground-truth positions.

The layout, shared by real labelled images, `pete-jetson detector synth` and the simulator's
`pete-sim dataset`:

    DIR/images/NAME.png|jpg     colour image
    DIR/labels/NAME.txt         YOLO labels, one ring per line: "0 cx cy w h", normalised to
                                [0, 1] by the image's width and height; no file or an empty file
                                means no rings
    DIR/depth/NAME.png          optional: depth aligned with the image, uint16 millimetres, 0 = none
    DIR/truth/NAME.json         optional: {"rings_robot_xy": [[x, y], ...]}, metres in the robot
                                frame (x right, y forward), one entry per label line, same order
    DIR/dataset.json            optional: {"format": "pete-rings", "version": 1,
                                "intrinsics": {...}, "mount": {...}, ...} for the camera that took
                                the images (needed to localise from depth)

Only class 0 (ring) is read; lines of other classes are skipped. A box of zero width or height
(a labelling tool's stray click: the public BLRSAI export holds one) marks no ring pixels; it is
skipped and named in `RingDataset.skipped_labels`, so that one such line does not make a whole
folder unusable. Every other malformed line is an error naming its file and line.

Held-out splits (holdout_names) keep every augmented copy of a source image on one side: a
Roboflow export names copies "SOURCE_jpg.rf.HASH", so copies share the part before ".rf.", and
a model validated on a blurred copy of a training image would be measured on what it has seen.
"""

from __future__ import annotations

import copy
import hashlib
import json
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.errors import DatasetError
from jetson.perception.frame import depth_from_mm, depth_to_mm

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")
DATASET_FORMAT = "pete-rings"
DATASET_VERSION = 1
RING_CLASS = 0


@dataclass(frozen=True)
class Sample:
    name: str
    image: Path
    label: Path | None
    depth: Path | None
    truth: Path | None


def parse_labels(text: str, where: str, skipped: list[str] | None = None) -> NDArray[np.float64]:
    """Ring boxes (N, 4) as normalised (cx, cy, w, h) from YOLO label text; zero-size boxes
    are left out and, when `skipped` is given, listed there as "where:line: text"."""
    rows = []
    for n, line in enumerate(text.splitlines(), start=1):
        parts = line.split()
        if not parts:
            continue
        if len(parts) != 5:
            raise DatasetError(
                f"{where}:{n}: expected 'class cx cy w h' (5 fields), got {len(parts)}: {line!r}"
            )
        try:
            cls = int(parts[0])
            cx, cy, w, h = (float(p) for p in parts[1:])
        except ValueError as exc:
            raise DatasetError(f"{where}:{n}: not numbers: {line!r}") from exc
        if not all(np.isfinite([cx, cy, w, h])):
            raise DatasetError(f"{where}:{n}: values must be finite: {line!r}")
        eps = 1e-3
        inside = -eps <= cx <= 1 + eps and -eps <= cy <= 1 + eps
        if inside and 0 <= w <= 1 + eps and 0 <= h <= 1 + eps and (w == 0 or h == 0):
            if skipped is not None:
                skipped.append(f"{where}:{n}: {line.strip()}")
            continue
        if not (inside and 0 < w <= 1 + eps and 0 < h <= 1 + eps):
            raise DatasetError(
                f"{where}:{n}: box outside the image or empty (values are normalised to "
                f"[0, 1]): {line!r}"
            )
        if cls == RING_CLASS:
            rows.append((cx, cy, w, h))
    return np.asarray(rows, dtype=np.float64).reshape(-1, 4)


def yolo_to_pixels(norm: NDArray[np.float64], width: int, height: int) -> NDArray[np.float64]:
    """Normalised (cx, cy, w, h) to pixel (x0, y0, x1, y1)."""
    cx, cy, w, h = norm[:, 0] * width, norm[:, 1] * height, norm[:, 2] * width, norm[:, 3] * height
    return np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)


def pixels_to_yolo(boxes: NDArray[np.float64], width: int, height: int) -> NDArray[np.float64]:
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return np.stack(
        [
            (b[:, 0] + b[:, 2]) / 2 / width,
            (b[:, 1] + b[:, 3]) / 2 / height,
            (b[:, 2] - b[:, 0]) / width,
            (b[:, 3] - b[:, 1]) / height,
        ],
        axis=1,
    )


def source_group(name: str) -> str:
    """The source image a sample was made from (see the module's doc)."""
    return name.split(".rf.")[0]


def holdout_names(names: list[str], fraction: float, seed: int = 0) -> set[str]:
    """The names held out for validation: whole source groups, each held out with probability
    `fraction` by a hash of its name, so the split is the same on every machine."""
    if not 0.0 <= fraction < 1.0:
        raise DatasetError(f"holdout fraction must be in [0, 1), got {fraction}")
    cut = round(fraction * 10_000)
    out = set()
    for name in names:
        h = zlib.crc32(f"{seed}:{source_group(name)}".encode()) % 10_000
        if h < cut:
            out.add(name)
    return out


def fingerprint(names: list[str]) -> str:
    """A short hash of a folder's image names: the same folder on any machine, at any path."""
    return hashlib.sha1("\n".join(sorted(names)).encode()).hexdigest()[:16]


def image_files(root: Path) -> list[Path]:
    """A dataset folder's images, sorted; an error naming the problem when there are none."""
    images = root / "images"
    if not root.is_dir():
        raise DatasetError(f"dataset folder {root} does not exist")
    if not images.is_dir():
        hint = ""
        subs = sorted(p.name for p in root.iterdir() if (p / "images").is_dir())
        if subs:
            hint = f"; it has split folders {subs}: point at one of them"
        raise DatasetError(
            f"{root} has no images/ folder (a YOLO dataset needs images/ and labels/){hint}"
        )
    files = sorted(p for p in images.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise DatasetError(f"{images} holds no images ({', '.join(IMAGE_SUFFIXES)})")
    return files


def image_names(root: Path | str) -> list[str]:
    """The sample names of a dataset folder without reading its labels: enough to recognise a
    folder (fingerprint) or split it (holdout_names) before opening it."""
    return [p.stem for p in image_files(Path(root))]


class RingDataset:
    """A dataset folder (see the module's doc): labels read when it opens, images when asked.

    `keep`, when given, restricts the dataset to the samples whose names it holds.
    """

    def __init__(self, root: Path | str, keep: set[str] | None = None) -> None:
        self.root = Path(root)
        self.samples = [self._sample(p) for p in image_files(self.root)]
        if keep is not None:
            self.samples = [s for s in self.samples if s.name in keep]
            if not self.samples:
                raise DatasetError(f"{self.root}: none of its images are in the selection")
        self.meta = self._meta()
        # Labels are read up front: a malformed file is an error before any work starts, and
        # the empty boxes left out are known (skipped_labels) before anything is scored.
        self.skipped_labels: list[str] = []
        self._boxes = [self._read_labels(s.label) for s in self.samples]

    def _read_labels(self, label: Path | None) -> NDArray[np.float64]:
        if label is None:
            return np.zeros((0, 4))
        try:
            text = label.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise DatasetError(f"{label} cannot be read: {exc}") from exc
        return parse_labels(text, str(label), self.skipped_labels)

    def skipped_note(self) -> str | None:
        """One line naming the empty boxes left out, for the user; None when there are none."""
        n = len(self.skipped_labels)
        if not n:
            return None
        more = f" (and {n - 1} more)" if n > 1 else ""
        return f"{self.root}: left out {n} empty label box(es): {self.skipped_labels[0]}{more}"

    @property
    def names(self) -> list[str]:
        return [s.name for s in self.samples]

    def subset(self, keep: set[str]) -> RingDataset:
        """The samples whose names `keep` holds, without reading the folder again."""
        picked = [i for i, s in enumerate(self.samples) if s.name in keep]
        if not picked:
            raise DatasetError(f"{self.root}: none of its images are in the selection")
        out = copy.copy(self)
        out.samples = [self.samples[i] for i in picked]
        out._boxes = [self._boxes[i] for i in picked]
        labels = tuple(f"{s.label}:" for s in out.samples if s.label is not None)
        out.skipped_labels = [x for x in self.skipped_labels if x.startswith(labels)]
        return out

    def _sample(self, image: Path) -> Sample:
        def opt(folder: str, suffix: str) -> Path | None:
            p = self.root / folder / (image.stem + suffix)
            return p if p.is_file() else None

        return Sample(
            image.stem, image, opt("labels", ".txt"), opt("depth", ".png"), opt("truth", ".json")
        )

    def _meta(self) -> dict[str, Any] | None:
        path = self.root / "dataset.json"
        if not path.is_file():
            return None
        try:
            data = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise DatasetError(f"{path} cannot be read: {exc}") from exc
        if not isinstance(data, dict) or data.get("format") != DATASET_FORMAT:
            raise DatasetError(f"{path} is not a {DATASET_FORMAT} description")
        return data

    def __len__(self) -> int:
        return len(self.samples)

    def image(self, i: int) -> NDArray[np.uint8]:
        path = self.samples[i].image
        img = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if img is None:
            raise DatasetError(f"{path} is not a readable image")
        return img

    def boxes_normalised(self, i: int) -> NDArray[np.float64]:
        return self._boxes[i].copy()

    def boxes(self, i: int, width: int, height: int) -> NDArray[np.float64]:
        """Ring boxes in pixels (x0, y0, x1, y1) for an image of the given size."""
        return yolo_to_pixels(self.boxes_normalised(i), width, height)

    def depth(self, i: int) -> NDArray[np.float32] | None:
        path = self.samples[i].depth
        if path is None:
            return None
        raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if raw is None or raw.dtype != np.uint16 or raw.ndim != 2:
            raise DatasetError(f"{path} must be a single-channel 16-bit PNG (millimetres)")
        return depth_from_mm(raw)

    def truth(self, i: int) -> NDArray[np.float64] | None:
        path = self.samples[i].truth
        if path is None:
            return None
        try:
            data = json.loads(path.read_text())
            xy = np.asarray(data["rings_robot_xy"], dtype=np.float64).reshape(-1, 2)
        except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            msg = f"{path}: expected {{'rings_robot_xy': [[x, y], ...]}}: {exc}"
            raise DatasetError(msg) from exc
        return xy


def write_meta(root: Path, meta: dict[str, Any]) -> None:
    root.mkdir(parents=True, exist_ok=True)
    data = {"format": DATASET_FORMAT, "version": DATASET_VERSION, **meta}
    (root / "dataset.json").write_text(json.dumps(data, indent=2) + "\n")


def write_sample(
    root: Path,
    name: str,
    bgr: NDArray[np.uint8],
    boxes_px: NDArray[np.float64],
    depth_m: NDArray[np.float32] | None = None,
    rings_robot_xy: NDArray[np.float64] | None = None,
) -> None:
    """Write one sample in the folder layout above."""
    for sub in (
        ("images", "labels")
        + (("depth",) if depth_m is not None else ())
        + (("truth",) if rings_robot_xy is not None else ())
    ):
        (root / sub).mkdir(parents=True, exist_ok=True)
    h, w = bgr.shape[:2]
    if not cv2.imwrite(str(root / "images" / f"{name}.png"), bgr):
        raise DatasetError(f"cannot write {root / 'images' / name}.png")
    norm = pixels_to_yolo(boxes_px, w, h)
    lines = [f"{RING_CLASS} {cx:.6f} {cy:.6f} {bw:.6f} {bh:.6f}" for cx, cy, bw, bh in norm]
    (root / "labels" / f"{name}.txt").write_text("".join(line + "\n" for line in lines))
    if depth_m is not None:
        cv2.imwrite(str(root / "depth" / f"{name}.png"), depth_to_mm(depth_m))
    if rings_robot_xy is not None:
        xy = np.asarray(rings_robot_xy, dtype=np.float64).reshape(-1, 2)
        if len(xy) != len(norm):
            raise DatasetError(f"{name}: {len(xy)} ring positions for {len(norm)} labels")
        payload = {"rings_robot_xy": [[round(x, 5), round(y, 5)] for x, y in xy]}
        (root / "truth" / f"{name}.json").write_text(json.dumps(payload) + "\n")
