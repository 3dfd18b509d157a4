"""Training RingNet from scratch on dataset folders and/or synthetic frames (needs torch).

    pete-jetson detector train --data DIR [--data DIR2] [--synthetic N] --out runs/ringnet.onnx

Each source (a folder, or the synthetic frames) is drawn equally often, whatever its size, so a
small real set is not drowned by thousands of renders. Every step takes a batch of random patches
(cnn/augment.py), builds CenterNet targets at stride 4 and minimises the focal loss on the heatmap
plus L1 on the offsets and log sizes; ignore regions (rings too hidden to label, rings cut small by
the patch's edge) count as neither ring nor background. At the end the model is exported to ONNX,
the score threshold that maximises F1 on the validation frames is chosen through the ONNX runtime
(the same code the Jetson runs), and NAME.onnx, NAME.json (metadata and metrics) and NAME.pt
(weights) are written.
"""

from __future__ import annotations

import json
import math
import pickle
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np
import torch
from numpy.typing import NDArray
from torch.nn import functional

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.errors import DatasetError
from jetson.perception.cnn.augment import AugmentConfig, augment
from jetson.perception.cnn.model import STRIDE, RingNet, export_onnx
from jetson.perception.cnn.runtime import (
    DEFAULT_MAX_UPSCALE,
    MODEL_FORMAT,
    MODEL_VERSION,
    CnnDetector,
    metadata_path,
)
from jetson.perception.dataset import RingDataset, fingerprint, holdout_names, image_names
from jetson.perception.evaluate import Counts, match
from jetson.perception.synthetic import random_frame

Image = NDArray[np.uint8]
Boxes = NDArray[np.float64]


@dataclass
class TrainConfig:
    data: list[Path] = field(default_factory=list)
    val_data: list[Path] = field(default_factory=list)
    synthetic: int = 0  # synthetic training frames rendered in memory
    synthetic_val: int = 64  # synthetic validation frames when there is no val_data
    synthetic_seed: int = 1_000_000  # training scenes use seeds from here up
    # Hold out this fraction of each --data folder's source images for validation (whole
    # source groups, dataset.holdout_names), recorded in the metadata so that evaluation on
    # that folder can use the held-out images only.
    holdout: float = 0.0
    holdout_seed: int = 0
    steps: int = 1500
    batch: int = 16
    patch: tuple[int, int] = (192, 160)  # width, height; multiples of 16
    lr: float = 3e-3
    weight_decay: float = 1e-4
    width: int = 16
    blocks: int = 1  # 3x3 convolutions after the down-sampling in stages 3 and 4 (RingNet)
    giou_weight: float = 0.0  # weight of a GIoU term on the boxes beside L1 on their log sizes
    strong_cast: float = 0.0  # share of samples lit by strongly coloured light (AugmentConfig)
    seed: int = 0
    threads: int = 2
    # Start from these weights (a .pt that detector train wrote, e.g. jetson/models/ringnet.pt)
    # instead of from scratch: fine-tuning on a team's own photos, or training on.
    init: Path | None = None
    input_long_side: int = 320
    # Training images are stored at most this big, and never smaller than the network sees them
    # (input_long_side), so a larger input gets the detail it is for.
    max_side: int = 480


@dataclass
class Source:
    name: str
    images: list[Image]
    boxes: list[Boxes]
    # Per image, regions that are neither ring nor background (YOLO folders have none).
    ignore: list[Boxes] | None = None
    note: str | None = None  # the empty label boxes the folder left out (RingDataset)

    def ignore_of(self, i: int) -> Boxes:
        return np.zeros((0, 4)) if self.ignore is None else self.ignore[i]


def load_folder(path: Path, max_side: int, keep: set[str] | None = None, tag: str = "") -> Source:
    ds = RingDataset(path, keep)
    images, boxes = [], []
    for i in range(len(ds)):
        img = ds.image(i)
        h, w = img.shape[:2]
        b = ds.boxes(i, w, h)
        s = min(1.0, max_side / max(w, h))
        if s < 1.0:
            img = cv2.resize(img, (round(w * s), round(h * s)), interpolation=cv2.INTER_AREA)
            b = b * s
        images.append(img)
        boxes.append(b)
    return Source(f"{path}{tag}", images, boxes, note=ds.skipped_note())


def synthetic_source(n: int, seed: int, size: tuple[int, int] = (320, 240)) -> Source:
    """n random scenes, each from its own seed (seed, seed + 1, ...), with a randomised mount."""
    images, boxes, ignore = [], [], []
    for k in range(n):
        rng = np.random.default_rng(seed + k)
        mount = CameraMount(
            forward_m=rng.uniform(0.05, 0.3),
            height_m=rng.uniform(0.18, 0.5),
            tilt_deg=rng.uniform(-45.0, -12.0),
        )
        r = random_frame(rng, Intrinsics().scaled(*size), mount, max_rings=10, decoys=True)
        images.append(r.frame.color)
        boxes.append(r.boxes)
        ignore.append(r.ignore_boxes)
    return Source(f"synthetic[{seed}..{seed + n - 1}]", images, boxes, ignore)


def make_targets(
    boxes: list[Boxes], width: int, height: int
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Heatmap (B, 1, Hc, Wc), box terms (B, 4, Hc, Wc) and their mask (B, 1, Hc, Wc)."""
    wc, hc = width // STRIDE, height // STRIDE
    heat = np.zeros((len(boxes), 1, hc, wc), np.float32)
    reg = np.zeros((len(boxes), 4, hc, wc), np.float32)
    mask = np.zeros((len(boxes), 1, hc, wc), np.float32)
    gx, gy = np.meshgrid(np.arange(wc), np.arange(hc))
    for n, bs in enumerate(boxes):
        for x0, y0, x1, y1 in bs:
            cx, cy = (x0 + x1) / 2 / STRIDE, (y0 + y1) / 2 / STRIDE
            bw, bh = (x1 - x0) / STRIDE, (y1 - y0) / STRIDE
            ix, iy = min(int(cx), wc - 1), min(int(cy), hc - 1)
            sx, sy = max(0.6, bw / 6), max(0.6, bh / 6)
            g = np.exp(-((gx - ix) ** 2) / (2 * sx * sx) - ((gy - iy) ** 2) / (2 * sy * sy))
            np.maximum(heat[n, 0], g.astype(np.float32), out=heat[n, 0])
            heat[n, 0, iy, ix] = 1.0
            reg[n, :, iy, ix] = (cx - ix, cy - iy, math.log(max(bw, 0.1)), math.log(max(bh, 0.1)))
            mask[n, 0, iy, ix] = 1.0
    return torch.from_numpy(heat), torch.from_numpy(reg), torch.from_numpy(mask)


def ignore_mask(ignore: list[Boxes], width: int, height: int) -> torch.Tensor:
    """(B, 1, Hc, Wc): 1 in every cell an ignore box touches, where no loss calls it background."""
    wc, hc = width // STRIDE, height // STRIDE
    out = np.zeros((len(ignore), 1, hc, wc), np.float32)
    for n, bs in enumerate(ignore):
        for x0, y0, x1, y1 in bs:
            c0, r0 = int(x0 // STRIDE), int(y0 // STRIDE)
            c1, r1 = math.ceil(x1 / STRIDE), math.ceil(y1 / STRIDE)
            out[n, 0, max(r0, 0) : min(r1, hc), max(c0, 0) : min(c1, wc)] = 1.0
    return torch.from_numpy(out)


def giou_loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Sum of 1 - GIoU over boxes given as (N, 4) centre x, centre y, width, height."""

    def corners(b: torch.Tensor) -> tuple[torch.Tensor, ...]:
        return (
            b[:, 0] - b[:, 2] / 2,
            b[:, 1] - b[:, 3] / 2,
            b[:, 0] + b[:, 2] / 2,
            b[:, 1] + b[:, 3] / 2,
        )

    px0, py0, px1, py1 = corners(pred)
    tx0, ty0, tx1, ty1 = corners(target)
    iw = (torch.minimum(px1, tx1) - torch.maximum(px0, tx0)).clamp(min=0)
    ih = (torch.minimum(py1, ty1) - torch.maximum(py0, ty0)).clamp(min=0)
    inter = iw * ih
    union = pred[:, 2] * pred[:, 3] + target[:, 2] * target[:, 3] - inter
    hull = (torch.maximum(px1, tx1) - torch.minimum(px0, tx0)) * (
        torch.maximum(py1, ty1) - torch.minimum(py0, ty0)
    )
    giou = inter / union.clamp(min=1e-6) - (hull - union) / hull.clamp(min=1e-6)
    return (1 - giou).sum()


def loss_fn(
    raw: torch.Tensor,
    heat: torch.Tensor,
    reg: torch.Tensor,
    mask: torch.Tensor,
    giou_weight: float = 0.0,
    ignore: torch.Tensor | None = None,
) -> tuple[torch.Tensor, dict[str, float]]:
    p = torch.sigmoid(raw[:, 0:1]).clamp(1e-4, 1 - 1e-4)
    pos = heat.eq(1.0).float()
    n_pos = pos.sum().clamp(min=1.0)
    pos_loss = -(torch.log(p) * (1 - p) ** 2 * pos).sum()
    neg = (1 - heat) ** 4 * (1 - pos)
    if ignore is not None:
        neg = neg * (1 - ignore)
    neg_loss = -(torch.log(1 - p) * p**2 * neg).sum()
    focal = (pos_loss + neg_loss) / n_pos
    offset = functional.l1_loss(
        torch.sigmoid(raw[:, 1:3]) * mask, reg[:, 0:2] * mask, reduction="sum"
    )
    size = functional.l1_loss(raw[:, 3:5] * mask, reg[:, 2:4] * mask, reduction="sum")
    total = focal + (offset + size) / n_pos
    parts = {
        "focal": float(focal.detach()),
        "offset": float(offset.detach() / n_pos),
        "size": float(size.detach() / n_pos),
    }
    if giou_weight > 0:
        # L1 on log sizes treats a box too tall like one too wide; the match needs IoU >= 0.5,
        # and a ring half hidden has a box whose extent matters more than its centre.
        at = mask[:, 0] > 0
        p_raw, t = raw.permute(0, 2, 3, 1)[at], reg.permute(0, 2, 3, 1)[at]
        pred = torch.cat([torch.sigmoid(p_raw[:, 1:3]), p_raw[:, 3:5].clamp(-4, 6).exp()], 1)
        target = torch.cat([t[:, 0:2], t[:, 2:4].exp()], 1)
        giou = giou_loss(pred, target) / n_pos
        total = total + giou_weight * giou
        parts["giou"] = float(giou.detach())
    return total, parts


def _batch(
    rng: np.random.Generator, sources: list[Source], cfg: TrainConfig, aug: AugmentConfig
) -> tuple[torch.Tensor, list[Boxes], list[Boxes]]:
    imgs, boxes, ignore = [], [], []
    for _ in range(cfg.batch):
        src = sources[int(rng.integers(len(sources)))]
        i = int(rng.integers(len(src.images)))
        image = src.images[i]
        base = cfg.input_long_side / max(image.shape[:2])
        img, b, ig = augment(rng, image, src.boxes[i], cfg.patch, aug, base, src.ignore_of(i))
        imgs.append(cv2.cvtColor(img, cv2.COLOR_BGR2RGB))
        boxes.append(b)
        ignore.append(ig)
    x = torch.from_numpy(np.stack(imgs).transpose(0, 3, 1, 2).astype(np.float32) / 255.0)
    return x, boxes, ignore


def evaluate(detector: CnnDetector, source: Source, thresholds: list[float]) -> dict[float, Counts]:
    """Counts at each threshold (detections are computed once, at the lowest). A detection of
    an ignore region is neither a hit nor a false alarm, as in training."""
    detector.threshold = min(thresholds)
    out = {t: Counts() for t in thresholds}
    for i, (img, truth) in enumerate(zip(source.images, source.boxes, strict=True)):
        dets = detector.detect(img)
        for t in thresholds:
            kept = [d for d in dets if d.score >= t]
            hits = match(kept, truth)
            found = {k for k, _ in hits}
            rest = [d for k, d in enumerate(kept) if k not in found]
            ignored = len(match(rest, source.ignore_of(i)))
            out[t].add(len(kept) - ignored, len(truth), len(hits))
    return out


def load_weights(net: RingNet, path: Path) -> None:
    """Weights from a .pt into `net`; a file that is not RingNet weights of net's shape is a
    DatasetError naming what it holds."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (OSError, RuntimeError, ValueError, EOFError, pickle.UnpicklingError) as exc:
        raise DatasetError(f"--init {path}: not readable as RingNet weights ({exc})") from exc
    if not isinstance(state, dict) or "stem.0.weight" not in state:
        raise DatasetError(f"--init {path}: not a RingNet state dict (no stem.0.weight)")
    width = int(state["stem.0.weight"].shape[0])
    blocks = len({k.split(".")[1] for k in state if k.startswith("stage3.")}) - 1
    if (width, blocks) != (net.width, net.blocks):
        raise DatasetError(
            f"--init {path} holds a RingNet with --width {width} --blocks {blocks}, "
            f"not {net.width} and {net.blocks}: pass those"
        )
    net.load_state_dict(state)


def init_lineage(init: Path) -> list[dict[str, object]]:
    """The rounds of training behind the weights at `init`, oldest first, read from the metadata
    written beside them, so that a model trained on from another carries how that one was made.
    Weights with no readable metadata are one round of which only the path is known."""
    try:
        earlier = json.loads(metadata_path(init).read_text())
    except (OSError, ValueError):
        return [{"weights": str(init), "metadata": "none readable"}]
    if not isinstance(earlier, dict):
        return [{"weights": str(init), "metadata": "not a JSON object"}]
    rounds = earlier.get("lineage", [])
    this = {k: earlier[k] for k in ("training", "trained_on", "validation") if k in earlier}
    return [*(rounds if isinstance(rounds, list) else []), {"weights": str(init), **this}]


def train(cfg: TrainConfig, out: Path, log: Callable[[str], None] = print) -> dict[str, object]:
    if not cfg.data and cfg.synthetic <= 0:
        raise DatasetError("nothing to train on: give --data DIR and/or --synthetic N")
    if out.suffix != ".onnx":
        raise DatasetError(f"--out must name a .onnx file, got {out}")
    if not 64 <= cfg.input_long_side <= 1280:
        raise DatasetError(f"--input-long-side must be 64-1280 pixels, got {cfg.input_long_side}")
    if cfg.width < 1 or not 0 <= cfg.blocks <= 8:
        raise DatasetError(f"--width must be >= 1 and --blocks 0-8, got {cfg.width}, {cfg.blocks}")
    if not 0.0 <= cfg.strong_cast <= 1.0:
        raise DatasetError(f"--strong-cast is a share of samples, 0-1, got {cfg.strong_cast}")
    torch.manual_seed(cfg.seed)
    torch.set_num_threads(cfg.threads)
    rng = np.random.default_rng(cfg.seed)
    t0 = time.monotonic()
    sources, val = [], []
    max_side = max(cfg.max_side, cfg.input_long_side)
    for p in cfg.data:
        if cfg.holdout > 0:
            names = image_names(p)
            held = holdout_names(names, cfg.holdout, cfg.holdout_seed)
            sources.append(load_folder(p, max_side, set(names) - held, " (minus held out)"))
            val.append(load_folder(p, max_side, held, " (held out)"))
        else:
            sources.append(load_folder(p, max_side))
    if cfg.synthetic > 0:
        sources.append(synthetic_source(cfg.synthetic, cfg.synthetic_seed))
    for s in sources:
        n_boxes = sum(len(b) for b in s.boxes)
        log(f"source {s.name}: {len(s.images)} images, {n_boxes} rings")
    val += [load_folder(p, max_side) for p in cfg.val_data]
    # A folder given twice reports its empty boxes once; its two halves each their own.
    for note in dict.fromkeys(s.note for s in sources + val if s.note):
        log(note)
    if cfg.synthetic_val > 0 and (cfg.synthetic > 0 or not val):
        # Seeds below the training ones: validation scenes are never training scenes.
        val.append(synthetic_source(cfg.synthetic_val, cfg.synthetic_seed - 10_000))
    log(f"data ready in {time.monotonic() - t0:.1f} s")

    net = RingNet(cfg.width, cfg.blocks)
    if cfg.init is not None:
        load_weights(net, cfg.init)
        log(f"starting from {cfg.init}")
    opt = torch.optim.AdamW(net.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    warm = min(100, cfg.steps // 10)

    def lr_at(step: int) -> float:
        if step < warm:
            return (step + 1) / warm
        return 0.5 * (1 + math.cos(math.pi * (step - warm) / max(1, cfg.steps - warm)))

    sched = torch.optim.lr_scheduler.LambdaLR(opt, lr_at)
    aug = AugmentConfig(strong_cast_p=cfg.strong_cast)
    net.train()
    t0 = time.monotonic()
    running: dict[str, float] = {}
    for step in range(cfg.steps):
        x, boxes, ignore = _batch(rng, sources, cfg, aug)
        heat, reg, mask = make_targets(boxes, cfg.patch[0], cfg.patch[1])
        skip = ignore_mask(ignore, cfg.patch[0], cfg.patch[1])
        loss, parts = loss_fn(net(x), heat, reg, mask, cfg.giou_weight, skip)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        for k, v in parts.items():
            running[k] = 0.9 * running.get(k, v) + 0.1 * v
        if (step + 1) % 50 == 0 or step == 0:
            terms = " ".join(f"{k} {v:.3f}" for k, v in running.items())
            log(f"step {step + 1}/{cfg.steps}  {terms}  {time.monotonic() - t0:.0f} s")

    net.eval()
    export_onnx(net, out, 240, 320)
    torch.save(net.state_dict(), out.with_suffix(".pt"))
    meta: dict[str, object] = {
        "format": MODEL_FORMAT,
        "version": MODEL_VERSION,
        "stride": STRIDE,
        "input_long_side": cfg.input_long_side,
        "score_threshold": 0.4,
        "max_upscale": DEFAULT_MAX_UPSCALE,
        "width": cfg.width,
        "blocks": cfg.blocks,
        "trained_on": [s.name for s in sources],
        "validated_on": [s.name for s in val],
        "training": {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(cfg).items()},
    }
    meta["training"]["data"] = [str(p) for p in cfg.data]  # type: ignore[index]
    meta["training"]["val_data"] = [str(p) for p in cfg.val_data]  # type: ignore[index]
    meta["training"]["init"] = str(cfg.init) if cfg.init else None  # type: ignore[index]
    if cfg.init is not None:
        meta["lineage"] = init_lineage(cfg.init)
    prints = [fingerprint(image_names(p)) for p in cfg.data]
    meta["data_fingerprints"] = prints
    if cfg.holdout > 0:
        meta["holdout"] = {
            "fraction": cfg.holdout,
            "seed": cfg.holdout_seed,
            "fingerprints": prints,
        }
    metadata_path(out).write_text(json.dumps(meta, indent=2) + "\n")
    detector = CnnDetector(out)
    thresholds = [0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.7]
    per_source = {s.name: evaluate(detector, s, thresholds) for s in val}
    # The threshold with the best mean F1 over the validation sources, so that a small real
    # set weighs as much as many synthetic frames.
    best = max(thresholds, key=lambda t: float(np.mean([c[t].f1 for c in per_source.values()])))
    meta["score_threshold"] = best
    meta["validation"] = {
        name: {
            "threshold": best,
            "precision": round(c[best].precision, 4),
            "recall": round(c[best].recall, 4),
            "f1": round(c[best].f1, 4),
        }
        for name, c in per_source.items()
    }
    meta["train_seconds"] = round(time.monotonic() - t0, 1)
    metadata_path(out).write_text(json.dumps(meta, indent=2) + "\n")
    for name, c in per_source.items():
        log(f"validation on {name} at threshold {best}: {c[best].summary()}")
    log(f"wrote {out}, {metadata_path(out)}, {out.with_suffix('.pt')}")
    return meta
