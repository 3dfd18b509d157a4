"""Checkerboard calibration on boards rendered with a known camera."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from jetson.cli import main
from jetson.errors import CalibrationError
from jetson.perception import calibrate
from jetson.perception.calibrate import (
    board_points,
    calibrate_folder,
    parse_board,
    reprojection_rms,
)

BOARD = (9, 6)  # inner corners
SQUARE_M = 0.025
TRUE_K = np.array([[610.0, 0.0, 328.0], [0.0, 605.0, 236.0], [0.0, 0.0, 1.0]])
TEXTURE_PPM = 2000.0  # texture pixels per metre (2 per mm)
MARGIN_SQUARES = 1.0


def board_texture() -> tuple[np.ndarray, float]:
    """A white-bordered board of (cols + 1) x (rows + 1) squares; returns it and the texture
    coordinate of the first inner corner (the same along x and y)."""
    cols, rows = BOARD[0] + 1, BOARD[1] + 1
    sq = round(SQUARE_M * TEXTURE_PPM)
    margin = round(MARGIN_SQUARES * sq)
    tex = np.full((rows * sq + 2 * margin, cols * sq + 2 * margin), 255, np.uint8)
    for r in range(rows):
        for c in range(cols):
            if (r + c) % 2 == 0:
                y, x = margin + r * sq, margin + c * sq
                tex[y : y + sq, x : x + sq] = 0
    return tex, margin + sq


def render_views(
    folder: Path, n: int = 8, seed: int = 0
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Write n views of the board; returns each file's true pose (rotation, translation)."""
    poses = {}
    rng = np.random.default_rng(seed)
    tex, origin = board_texture()
    texture_to_board = np.array(
        [[1 / TEXTURE_PPM, 0, -origin / TEXTURE_PPM], [0, 1 / TEXTURE_PPM, -origin / TEXTURE_PPM],
         [0, 0, 1]]
    )  # fmt: skip
    centre = np.array([(BOARD[0] - 1) * SQUARE_M / 2, (BOARD[1] - 1) * SQUARE_M / 2, 0.0])
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(n):
        rvec = np.radians([rng.uniform(-35, 35), rng.uniform(-35, 35), rng.uniform(-20, 20)])
        rot, _ = cv2.Rodrigues(rvec)
        # Put the board's centre somewhere in view, 0.45-0.7 m away.
        z = rng.uniform(0.45, 0.7)
        target = np.array([rng.uniform(-0.06, 0.06), rng.uniform(-0.04, 0.04), z])
        t = target - rot @ centre
        h = TRUE_K @ np.c_[rot[:, 0], rot[:, 1], t] @ texture_to_board
        img = cv2.warpPerspective(tex, h, (640, 480), flags=cv2.INTER_LINEAR, borderValue=128)
        img = cv2.GaussianBlur(img, (0, 0), 0.7)
        noisy = img + rng.normal(0, 2.0, img.shape)
        cv2.imwrite(str(folder / f"view{k:02d}.png"), np.clip(noisy, 0, 255).astype(np.uint8))
        poses[f"view{k:02d}.png"] = (rot, t)
    return poses


def test_calibration_recovers_a_known_camera_within_one_percent(tmp_path: Path) -> None:
    render_views(tmp_path / "views")
    cv2.imwrite(str(tmp_path / "views" / "blank.png"), np.full((480, 640), 128, np.uint8))
    cal = calibrate_folder(tmp_path / "views", BOARD, SQUARE_M)
    i = cal.intrinsics
    for got, want in ((i.fx, 610.0), (i.fy, 605.0), (i.cx, 328.0), (i.cy, 236.0)):
        assert got == pytest.approx(want, rel=0.01)
    assert cal.rms_px < 0.5
    assert cal.skipped == ["blank.png"]
    assert len(cal.per_image_rms_px) == 8


def true_corners(rot: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Where the inner corners really are in a view: the rendering camera's projection, (N, 2)."""
    cam = board_points(BOARD, SQUARE_M).astype(np.float64) @ rot.T + t
    uvw = cam @ TRUE_K.T
    return uvw[:, :2] / uvw[:, 2:]


@pytest.mark.parametrize("shape", ["N,2", "N,1,2"])
def test_each_image_reports_its_own_error_and_a_perturbed_one_is_named_worst(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, shape: str
) -> None:
    """One view's corner detections are moved by a non-rigid pattern (alternate corners
    +-1.5 px along x and y, which no pose can absorb): that view is named worst, with an error
    close to its true one, measured against the rendering camera; the others stay sharp. Both
    shapes OpenCV returns corners in are tried (OpenCV 5 gives (N, 2))."""
    poses = render_views(tmp_path / "views", n=8, seed=2)
    bad = "view05.png"
    bad_gray = cv2.imread(str(tmp_path / "views" / bad), cv2.IMREAD_GRAYSCALE)
    cols, rows = BOARD
    c, r = np.meshgrid(np.arange(cols), np.arange(rows))  # row by row, as OpenCV orders them
    sign = np.where((c + r).ravel() % 2 == 0, 1.0, -1.0)
    shift = 1.5 * np.c_[sign, np.where(c.ravel() % 2 == 0, 1.0, -1.0)]
    moved: list[np.ndarray] = []
    real = calibrate.find_corners

    def find(gray: np.ndarray, board: tuple[int, int]) -> np.ndarray | None:
        corners = real(gray, board)
        if corners is None:
            return None
        pts = corners.reshape(-1, 2).astype(np.float64)
        if np.array_equal(gray, bad_gray):
            pts = pts + shift
            moved.append(pts)
        out = pts.astype(np.float32)
        return out if shape == "N,2" else out.reshape(-1, 1, 2)

    monkeypatch.setattr(calibrate, "find_corners", find)
    cal = calibrate_folder(tmp_path / "views", BOARD, SQUARE_M)
    assert len(moved) == 1, "the perturbed view was read once"
    true_error = reprojection_rms(true_corners(*poses[bad]), moved[0])
    assert 2.0 < true_error < 2.3, "sqrt(1.5**2 + 1.5**2) plus the detector's own error"
    errors = cal.per_image_rms_px
    assert cal.summary()["worst_image"] == bad
    assert errors[bad] == pytest.approx(true_error, rel=0.1)
    assert all(e < 0.5 for name, e in errors.items() if name != bad), errors
    # The overall RMS is the per-image errors pooled (every view has the same corners).
    pooled = float(np.sqrt(np.mean(np.square(list(errors.values())))))
    assert cal.rms_px == pytest.approx(pooled, rel=1e-3)


def test_reprojection_error_takes_both_point_shapes_and_names_a_count_mismatch() -> None:
    a = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    b = a + np.array([[3.0, 4.0], [0.0, 0.0], [0.0, 0.0]])
    want = np.sqrt(25 / 3)
    assert reprojection_rms(a.reshape(-1, 1, 2), b) == pytest.approx(want)
    assert reprojection_rms(a, b.reshape(-1, 1, 2)) == pytest.approx(want)
    with pytest.raises(CalibrationError, match="3 projected corners against 2 detected"):
        reprojection_rms(a, b[:2])
    with pytest.raises(CalibrationError, match=r"expected \(N, 2\) or \(N, 1, 2\)"):
        reprojection_rms(a.reshape(1, 3, 2), b)


def test_board_points_follow_opencvs_order() -> None:
    pts = board_points((3, 2), 0.1)
    want = [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0], [0.2, 0.1, 0]]
    assert pts == pytest.approx(np.array(want), abs=1e-6)


def test_bad_boards_and_folders_are_named(tmp_path: Path) -> None:
    assert parse_board("9x6") == (9, 6)
    for bad in ("9", "9x", "ax6", "1x6"):
        with pytest.raises(CalibrationError, match=r"COLSxROWS|at least 2x2"):
            parse_board(bad)
    with pytest.raises(CalibrationError, match="different column and row"):
        parse_board("7x7")
    with pytest.raises(CalibrationError, match="does not exist"):
        calibrate_folder(tmp_path / "none", BOARD, SQUARE_M)
    with pytest.raises(CalibrationError, match="holds no images"):
        calibrate_folder(tmp_path, BOARD, SQUARE_M)
    render_views(tmp_path / "views", n=3)
    with pytest.raises(CalibrationError, match=r"found in 0 of 3 images.*INNER"):
        calibrate_folder(tmp_path / "views", (8, 5), SQUARE_M)


def test_calibrate_command_writes_the_camera_config(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    render_views(tmp_path / "views", n=6, seed=1)
    out = tmp_path / "camera.json"
    assert main(["calibrate", "--images", str(tmp_path / "views"), "--board", "9x6",
                 "--square-mm", "25", "--out", str(out)]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "reprojection error (RMS)" in printed
    data = json.loads(out.read_text())
    assert data["intrinsics"]["fx"] == pytest.approx(610.0, rel=0.01)
    assert data["mount"]["tilt_deg"] == -30.0
    assert data["calibration"]["images_used"] == 6
    assert main(["calibrate", "--images", str(tmp_path), "--board", "9x6",
                 "--square-mm", "25"]) == 2  # fmt: skip
    assert "holds no images" in capsys.readouterr().err
