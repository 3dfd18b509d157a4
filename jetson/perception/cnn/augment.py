"""Training-time augmentation (numpy and OpenCV): geometry, lighting, colour, blur, noise.

Everything that changes the image's geometry changes its boxes the same way. Colour shifts stay
small in hue (rings are purple on every field) but wide in brightness, contrast and saturation;
optionally a share of samples is lit by strongly coloured light (one channel a fifth of the
others, as in photos under coloured stage or LED light, where a purple ring turns dark green or
blue); a share goes through the pre-filter so the CNN also works on pre-filtered frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.perception.prefilter import PrefilterConfig, prefilter


@dataclass(frozen=True)
class AugmentConfig:
    scale_range: tuple[float, float] = (0.6, 1.5)  # around the scale the detector runs at
    aspect_jitter: float = 0.2  # log-uniform stretch of x against y
    flip: bool = True
    hue_shift: float = 6.0  # OpenCV hue units (0-180)
    saturation: tuple[float, float] = (0.6, 1.35)
    brightness: tuple[float, float] = (0.55, 1.45)
    contrast: tuple[float, float] = (0.7, 1.3)
    blur_p: float = 0.35
    motion_blur_p: float = 0.15
    noise_p: float = 0.5
    jpeg_p: float = 0.25
    prefilter_p: float = 0.2
    # Strongly coloured light: per-channel gains log-uniform in strong_cast_gain, then scaled to
    # keep the image's mean. The BLRSAI photos hold scenes whose channel means are 0.17-1.9 of
    # their average (a purple-lit and a green-lit room); the mild cast above never reaches them.
    # Off by default (detector train --strong-cast P) until a shipped model is trained with it.
    strong_cast_p: float = 0.0
    strong_cast_gain: tuple[float, float] = (0.15, 2.0)
    # A ring cut by the patch's edge stays a ring while this much of its box is left (patch
    # pixels; about the 40 pixels at 640x480 by which the simulator labels a ring cut by the
    # image's edge). A smaller remnant becomes an ignore region: its pixels are still in the
    # patch, and calling them background would teach the detector to miss rings at the edge.
    min_cut_area_px: float = 48.0
    min_box_px: float = 3.0


def _area(b: NDArray[np.float64]) -> NDArray[np.float64]:
    return (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])


def _clip_boxes(
    b: NDArray[np.float64], size: tuple[int, int]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Regions clipped to a (width, height) patch as rectangles, the area left and the area
    they had."""
    pw, ph = size
    clipped = np.clip(b, 0, [pw, ph, pw, ph])
    return clipped, _area(clipped), _area(b)


def _cut_rings(
    b: NDArray[np.float64], size: tuple[int, int]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Ring boxes cut by a (width, height) patch, the area left and the area they had.

    A ring is an ellipse in its box, and the datasets label a ring the image's edge cuts by the
    part that shows (the renderer by its visible pixels, people by eye): a sliver at the edge
    is shorter than the ring. A crop must label its cuts the same way, or the network learns
    full-height boxes for slivers and misses the IoU of every ring the frame's edge cuts. So a
    cut box shrinks to the bounds of its ellipse inside the patch.
    """
    pw, ph = size
    clipped, _, area = _clip_boxes(b, size)
    cx, cy = (b[:, 0] + b[:, 2]) / 2, (b[:, 1] + b[:, 3]) / 2
    ax = np.maximum((b[:, 2] - b[:, 0]) / 2, 1e-9)
    ay = np.maximum((b[:, 3] - b[:, 1]) / 2, 1e-9)
    # The ellipse's half-height at the patch column nearest its centre, and likewise across.
    tx = (np.clip(cx, 0, pw) - cx) / ax
    ty = (np.clip(cy, 0, ph) - cy) / ay
    half_h = ay * np.sqrt(np.clip(1 - tx**2, 0, None))
    half_w = ax * np.sqrt(np.clip(1 - ty**2, 0, None))
    tight = np.stack(
        [
            np.maximum(clipped[:, 0], cx - half_w),
            np.maximum(clipped[:, 1], cy - half_h),
            np.minimum(clipped[:, 2], cx + half_w),
            np.minimum(clipped[:, 3], cy + half_h),
        ],
        axis=1,
    )
    tight[:, 2:] = np.maximum(tight[:, 2:], tight[:, :2])  # a corner past the ellipse: empty
    return tight, _area(tight), area


def random_patch(
    rng: np.random.Generator,
    bgr: NDArray[np.uint8],
    boxes: NDArray[np.float64],
    size: tuple[int, int],
    cfg: AugmentConfig,
    base_scale: float = 1.0,
    ignore: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.uint8], NDArray[np.float64], NDArray[np.float64]]:
    """A (width, height) = size patch of a randomly scaled, stretched, flipped image, its ring
    boxes, and its ignore boxes (parts of rings that are neither ring nor background: `ignore`
    moved with the image, plus rings the patch's edge cut too small).

    base_scale is the resize the detector applies to this image at run time, so that rings in
    patches have the sizes the detector will meet, give or take cfg.scale_range.
    """
    pw, ph = size
    h, w = bgr.shape[:2]
    s = base_scale * rng.uniform(*cfg.scale_range)
    stretch = float(np.exp(rng.uniform(-cfg.aspect_jitter, cfg.aspect_jitter)))
    sx, sy = s * stretch, s / stretch
    # Crop origin in the scaled image; when the image is smaller than the patch it is padded.
    sw, sh = w * sx, h * sy
    ox = rng.uniform(min(0.0, sw - pw), max(0.0, sw - pw))
    oy = rng.uniform(min(0.0, sh - ph), max(0.0, sh - ph))
    m = np.array([[sx, 0.0, -ox], [0.0, sy, -oy]])
    fill = tuple(int(v) for v in rng.integers(0, 256, 3))
    out = cv2.warpAffine(
        bgr, m, (pw, ph), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=fill
    )
    scale, shift = np.array([sx, sy, sx, sy]), np.array([ox, oy, ox, oy])
    clipped, left, area = _cut_rings(boxes.reshape(-1, 4) * scale - shift, size)
    big_enough = (clipped[:, 2] - clipped[:, 0] >= cfg.min_box_px) & (
        clipped[:, 3] - clipped[:, 1] >= cfg.min_box_px
    )
    # A ring the crop did not cut keeps its label whatever its size: the dataset labelled it.
    keep = big_enough & ((left >= cfg.min_cut_area_px) | (left >= area - 1e-6))
    b = clipped[keep]
    ign_all = np.zeros((0, 4)) if ignore is None else ignore.reshape(-1, 4)
    ign, ign_left, _ = _clip_boxes(ign_all * scale - shift, size)
    ig = np.concatenate([ign[ign_left > 0], clipped[~keep & (left > 0)]])
    if cfg.flip and rng.random() < 0.5:
        out = out[:, ::-1].copy()
        b = np.stack([pw - b[:, 2], b[:, 1], pw - b[:, 0], b[:, 3]], axis=1)
        ig = np.stack([pw - ig[:, 2], ig[:, 1], pw - ig[:, 0], ig[:, 3]], axis=1)
    return out, b, ig.reshape(-1, 4)


def photometric(
    rng: np.random.Generator, bgr: NDArray[np.uint8], cfg: AugmentConfig
) -> NDArray[np.uint8]:
    img = bgr
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV).astype(np.float32)
    hsv[..., 0] = (hsv[..., 0] + rng.uniform(-cfg.hue_shift, cfg.hue_shift)) % 180.0
    hsv[..., 1] *= rng.uniform(*cfg.saturation)
    img = cv2.cvtColor(np.clip(hsv, 0, 255).astype(np.uint8), cv2.COLOR_HSV2BGR)
    f = img.astype(np.float32)
    mean = f.mean()
    f = (f - mean) * rng.uniform(*cfg.contrast) + mean
    f *= rng.uniform(*cfg.brightness)
    # A colour cast: lighting that is not white.
    f *= rng.uniform(0.85, 1.15, 3).astype(np.float32)
    # Drawn only when enabled, so a config without it keeps the random stream (and the weights)
    # of the models trained before it.
    if cfg.strong_cast_p > 0 and rng.random() < cfg.strong_cast_p:
        lo, hi = np.log(cfg.strong_cast_gain)
        gain = np.exp(rng.uniform(lo, hi, 3)).astype(np.float32)
        before = float(f.mean())
        f *= gain
        f *= np.float32(before / max(float(f.mean()), 1e-3))
    if rng.random() < cfg.noise_p:
        f += rng.normal(0.0, rng.uniform(2.0, 10.0), f.shape).astype(np.float32)
    img = np.clip(f, 0, 255).astype(np.uint8)
    if rng.random() < cfg.blur_p:
        img = cv2.GaussianBlur(img, (0, 0), rng.uniform(0.5, 1.8))
    if rng.random() < cfg.motion_blur_p:
        k = int(rng.integers(3, 9))
        kernel = np.zeros((k, k), np.float32)
        kernel[k // 2, :] = 1.0 / k
        rot = cv2.getRotationMatrix2D((k / 2 - 0.5, k / 2 - 0.5), rng.uniform(0, 180), 1.0)
        kernel = cv2.warpAffine(kernel, rot, (k, k))
        kernel /= max(kernel.sum(), 1e-6)
        img = cv2.filter2D(img, -1, kernel)
    if rng.random() < cfg.jpeg_p:
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(rng.integers(30, 90))])
        if ok:
            img = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    if rng.random() < cfg.prefilter_p:
        img = prefilter(img, PrefilterConfig()).image
    return img


def augment(
    rng: np.random.Generator,
    bgr: NDArray[np.uint8],
    boxes: NDArray[np.float64],
    size: tuple[int, int],
    cfg: AugmentConfig,
    base_scale: float = 1.0,
    ignore: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.uint8], NDArray[np.float64], NDArray[np.float64]]:
    img, b, ig = random_patch(rng, bgr, boxes, size, cfg, base_scale, ignore)
    return photometric(rng, img, cfg), b, ig
