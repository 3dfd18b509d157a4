"""Checkerboard calibration of the colour camera with OpenCV.

    pete-jetson calibrate --images DIR --board 9x6 --square-mm 25 [--out camera.json]

--board counts INNER corners, columns x rows, as OpenCV's patternSize does (a board of 10 x 7
squares has 9 x 6 inner corners). Corners are refined to sub-pixel; images where the board is not
found are listed and skipped. The result is K and the distortion (k1, k2, p1, p2, k3), the RMS
reprojection error over all corners and per image, written into the camera config (the mount
already in that file is kept).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.errors import CalibrationError
from jetson.perception.dataset import IMAGE_SUFFIXES

MIN_VIEWS = 3


def parse_board(text: str) -> tuple[int, int]:
    """ "9x6" -> (9, 6): inner corners per row and per column."""
    cols, sep, rows = text.lower().partition("x")
    if not sep or not cols.isdigit() or not rows.isdigit():
        raise CalibrationError(f"--board must look like COLSxROWS (inner corners), got {text!r}")
    c, r = int(cols), int(rows)
    if c < 2 or r < 2:
        raise CalibrationError(f"a board needs at least 2x2 inner corners, got {c}x{r}")
    if c == r:
        # A square pattern has no defined orientation: corner order can flip between views.
        raise CalibrationError(f"use a board with different column and row counts, not {c}x{r}")
    return c, r


@dataclass
class Calibration:
    intrinsics: Intrinsics
    rms_px: float
    per_image_rms_px: dict[str, float] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)  # images where the board was not found

    def summary(self) -> dict[str, object]:
        return {
            "rms_px": round(self.rms_px, 4),
            "images_used": len(self.per_image_rms_px),
            "images_skipped": self.skipped,
            "worst_image": max(self.per_image_rms_px.items(), key=lambda kv: kv[1])[0]
            if self.per_image_rms_px
            else None,
        }


def board_points(board: tuple[int, int], square_m: float) -> NDArray[np.float32]:
    """The inner corners in the board's own frame (z = 0), row by row, as OpenCV orders them."""
    cols, rows = board
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2).astype(np.float32)
    return np.c_[grid * np.float32(square_m), np.zeros(len(grid), np.float32)]


def as_points(points: NDArray[np.floating], what: str) -> NDArray[np.float64]:
    """OpenCV's point arrays, (N, 1, 2) or (N, 2) depending on the function and the version,
    as (N, 2)."""
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim not in (2, 3) or arr.shape[-1] != 2 or (arr.ndim == 3 and arr.shape[1] != 1):
        raise CalibrationError(f"{what}: expected (N, 2) or (N, 1, 2) points, got {arr.shape}")
    return arr.reshape(-1, 2)


def reprojection_rms(projected: NDArray[np.floating], detected: NDArray[np.floating]) -> float:
    """The RMS distance, in pixels, between each corner's projection and its detection: one
    image's own error. Both arrays are taken to (N, 2) first, so that OpenCV's (N, 1, 2) and
    (N, 2) never broadcast into an N x N table of every pair."""
    proj = as_points(projected, "projected corners")
    seen = as_points(detected, "detected corners")
    if proj.shape != seen.shape:
        raise CalibrationError(
            f"{len(proj)} projected corners against {len(seen)} detected ones: the board's "
            "corner count differs between the two"
        )
    return float(np.sqrt(np.mean(np.sum((proj - seen) ** 2, axis=1))))


def find_corners(gray: NDArray[np.uint8], board: tuple[int, int]) -> NDArray[np.float32] | None:
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(gray, board, flags=flags)
    if not found:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    return cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), criteria)


def calibrate_folder(folder: Path, board: tuple[int, int], square_m: float) -> Calibration:
    if not folder.is_dir():
        raise CalibrationError(f"image folder {folder} does not exist")
    paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not paths:
        raise CalibrationError(f"{folder} holds no images ({', '.join(IMAGE_SUFFIXES)})")
    return calibrate_images(paths, board, square_m)


def calibrate_images(paths: list[Path], board: tuple[int, int], square_m: float) -> Calibration:
    if not square_m > 0:
        raise CalibrationError(f"square size must be positive, got {square_m} m")
    obj = board_points(board, square_m)
    size: tuple[int, int] | None = None
    object_points, image_points, names, skipped = [], [], [], []
    for path in paths:
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise CalibrationError(f"{path} is not a readable image")
        h, w = img.shape
        if size is None:
            size = (w, h)
        elif size != (w, h):
            raise CalibrationError(
                f"{path} is {w}x{h} but earlier images are {size[0]}x{size[1]}: calibrate one "
                "resolution at a time"
            )
        corners = find_corners(img, board)
        if corners is None:
            skipped.append(path.name)
            continue
        object_points.append(obj)
        image_points.append(corners)
        names.append(path.name)
    if len(image_points) < MIN_VIEWS or size is None:
        raise CalibrationError(
            f"the {board[0]}x{board[1]} board was found in {len(image_points)} of {len(paths)} "
            f"images; at least {MIN_VIEWS} are needed (is --board the count of INNER corners?)"
        )
    rms, k, dist, rvecs, tvecs = cv2.calibrateCamera(object_points, image_points, size, None, None)
    per_image = {}
    for name, op, ip, rv, tv in zip(names, object_points, image_points, rvecs, tvecs, strict=True):
        proj, _ = cv2.projectPoints(op, rv, tv, k, dist)
        per_image[name] = reprojection_rms(proj, ip)
    d = tuple(float(v) for v in np.ravel(dist)[:5])
    intr = Intrinsics(
        size[0], size[1], float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]), d
    )
    return Calibration(intr, float(rms), per_image, skipped)
