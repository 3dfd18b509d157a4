"""Benchmark of ring perception: detection quality, localisation error, pipeline speed.

    python -m bench.perception [--sim-data DIR | --synthetic] [--frames N] [--real DIR ...]
                               [--model PATH] [--strict]

1. A test set with ground truth, for each detector (pre-filter off): precision, recall and F1 at
   IoU 0.5, localisation error (median, p90) by true distance band, and recall by how much of
   each ring shows (its label's box over the whole ring's projected box: cut by the image's edge
   or hidden behind another ring, a ring shows less), with F1 when rings under a quarter visible
   count as VOC's 'difficult' objects (a diagnostic beside the target). By default the
   simulator's test set: N frames (default 500) that `pete-sim dataset --seed 0` renders into
   runs/bench-perception/sim-seed0-N/ the first time (a few minutes; later runs reuse it unless
   the simulator's scenes changed since: sim.dataset.SCENES_VERSION); the shipped detector
   trained on seed 100's frames, and each frame draws from its own (seed, frame) stream, so none
   is in both. --sim-data scores another such folder. --synthetic (or no
   PyBullet) uses N frames of jetson.perception's own numpy renderer instead ("synthetic_"
   metrics), from seeds 2,000,000 up, which no training run uses.
2. Real labelled images (YOLO folders; by default the shared BLRSAI set when it is present):
   precision, recall and F1 for each detector, with and without the pre-filter. --real is
   repeatable: each folder is scored alone (real1_, real2_, ...) and all of them pooled
   (real_: their counts summed, what the target reads). A folder the CNN trained on part of is
   scored on the part it held out. Skipped, with a message, when a folder is missing.
3. Frames per second of the whole pipeline (pre-filter + detector + localisation) on a 640x480
   frame with depth, one thread for OpenCV and onnxruntime: one core.

Targets (issue 6): F1 >= 0.95 on simulated frames and >= 0.85 on real images, median
localisation error <= 3 cm within 2 m, >= 60 frames/s; they are set on the default pipeline
(the CNN, pre-filter off). Results: bench/results/perception.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from bench.common import Result, median_ns, per_second
from jetson.autonomy.camera import Intrinsics
from jetson.errors import PerceptionError
from jetson.models import DEFAULT_DETECTOR
from jetson.perception.camera import CameraConfig
from jetson.perception.classical import ClassicalDetector
from jetson.perception.cnn.runtime import CnnDetector, metadata_path
from jetson.perception.dataset import RingDataset
from jetson.perception.detection import Detector
from jetson.perception.evaluate import Counts, DatasetScore, heldout_of, match, trained_on
from jetson.perception.localise import Localiser
from jetson.perception.pipeline import Pipeline
from jetson.perception.prefilter import PrefilterConfig
from jetson.perception.synthetic import random_frame

ROOT = Path(__file__).resolve().parent.parent
SHARED_REAL = ROOT.parent / "shared" / "datasets" / "blrsai-rings" / "train"
TEST_SEED = 2_000_000
BANDS = (0.0, 1.0, 2.0, 3.0)
DIFFICULT_BELOW = 0.25  # visible fraction under which a ring is 'difficult' (reported, no target)


def detectors(camera: CameraConfig, model: Path | None) -> dict[str, Detector]:
    out: dict[str, Detector] = {"classical": ClassicalDetector(camera=camera)}
    path = model or DEFAULT_DETECTOR
    try:
        out["cnn"] = CnnDetector(path, threads=1)
    except PerceptionError as exc:
        print(f"bench.perception: no CNN ({exc}); measuring the classical detector only")
    return out


def synthetic_scores(
    dets: dict[str, Detector], camera: CameraConfig, frames: int
) -> dict[str, DatasetScore]:
    """Score each detector on `frames` rendered frames, rendering each frame once."""
    scores = {name: DatasetScore(Counts(), 0, [], 0) for name in dets}
    pipes = {name: Pipeline(d, camera) for name, d in dets.items()}
    t0 = time.monotonic()
    for k in range(frames):
        r = random_frame(np.random.default_rng(TEST_SEED + k), camera.intrinsics, camera.mount)
        for name, pipe in pipes.items():
            res = pipe.process(r.frame)
            pairs = match(res.detections, r.boxes)
            s = scores[name]
            s.counts.add(len(res.detections), len(r.boxes), len(pairs))
            s.frames += 1
            placed = {id(e.detection): e for e in res.rings}
            for d, t in pairs:
                ring = placed.get(id(res.detections[d]))
                if ring is None:
                    s.unplaced += 1
                    continue
                truth = r.rings_robot_xy[t]
                err = float(np.hypot(*(np.asarray(ring.robot_xy) - truth)))
                s.localisation.append((float(np.hypot(*truth)), err))
        if (k + 1) % 100 == 0:
            print(f"  {k + 1}/{frames} frames, {time.monotonic() - t0:.0f} s", flush=True)
    return scores


def folder_scores(
    dets: dict[str, Detector], camera: CameraConfig, ds: RingDataset, prefilter: bool
) -> dict[str, DatasetScore]:
    from jetson.perception.evaluate import score_dataset

    cfg = PrefilterConfig(enabled=prefilter)
    return {name: score_dataset(Pipeline(d, camera, cfg), ds) for name, d in dets.items()}


def real_images(
    dets: dict[str, Detector],
    camera: CameraConfig,
    folders: list[Path],
    meta: dict[str, object] | None,
    result: Result,
) -> None:
    """Every detector with and without the pre-filter on real photos, per folder and pooled
    (`real_*`: the counts of all folders summed, the figure the target reads). Where the CNN
    trained on part of a folder, that folder is scored on the part it held out (and the
    classical detector, which never trains, on the whole folder as well)."""
    pooled: dict[str, Counts] = {}
    images = 0
    for k, folder in enumerate(folders, start=1):
        held = heldout_of(meta, folder)
        tag = f"real{k}" if len(folders) > 1 else "real"
        if held is not None:
            print(f"== real images {folder}: the {len(held)} images the CNN held out of training")
        else:
            print(f"== real images {folder}")
            if trained_on(meta, folder):
                print("   warning: the CNN trained on these images; its score here flatters it")
        whole = RingDataset(folder)
        ds = whole.subset(held) if held is not None else whole
        if note := ds.skipped_note():
            print(f"   {note}")
        images += len(ds)
        if len(folders) > 1:
            result.add(f"{tag}_images", len(ds))
        # Photos from unknown cameras and mounts: no floor-size prior for the classical detector.
        real_dets = dict(dets, classical=ClassicalDetector())
        for pre in (False, True):
            for name, score in folder_scores(real_dets, camera, ds, pre).items():
                key = f"{name}{'_prefilter' if pre else ''}"
                print(f"  {tag}_{key}: {score.counts.summary()}")
                if len(folders) > 1:
                    add_detection(result, f"{tag}_{key}", score.counts)
                c, t = score.counts, pooled.get(key, Counts())
                pooled[key] = Counts(t.tp + c.tp, t.fp + c.fp, t.fn + c.fn)
        if held is not None:
            score = folder_scores({"classical": ClassicalDetector()}, camera, whole, False)
            print(f"  {tag}_all_classical (all images): {score['classical'].counts.summary()}")
            add_detection(result, f"{tag}_all_classical", score["classical"].counts)
    result.add("real_images", images)
    if len(folders) > 1:
        print(f"== real images, the {len(folders)} folders pooled ({images} images)")
    for key, counts in pooled.items():
        if len(folders) > 1:
            print(f"  real_{key}: {counts.summary()}")
        add_detection(result, f"real_{key}", counts)


def add_detection(result: Result, prefix: str, c: Counts) -> None:
    result.add(f"{prefix}_precision", round(c.precision, 4))
    result.add(f"{prefix}_recall", round(c.recall, 4))
    result.add(f"{prefix}_f1", round(c.f1, 4))


def add_localisation(result: Result, prefix: str, score: DatasetScore) -> None:
    for lo, hi, n, med, p90 in score.localisation_bands(BANDS):
        band = f"{lo:.0f}_{hi:.0f}m"
        result.add(f"{prefix}_loc_{band}_rings", n)
        result.add(f"{prefix}_loc_{band}_median_m", round(med, 4))
        result.add(f"{prefix}_loc_{band}_p90_m", round(p90, 4))
    within = [e for d, e in score.localisation if d < 2.0]
    if within:
        result.add(f"{prefix}_loc_within_2m_median_m", round(float(np.median(within)), 4))


def add_visibility(result: Result, prefix: str, score: DatasetScore) -> None:
    """Recall by how much of each ring shows (a diagnostic: where the misses are), and F1 with
    rings under a quarter visible treated as VOC's 'difficult' objects. Neither is a target:
    the target counts every labelled ring."""
    for lo, hi, n, recall in score.recall_by_visibility():
        band = f"{lo * 100:.0f}_{hi * 100:.0f}pct"
        result.add(f"{prefix}_visible_{band}_rings", n)
        result.add(f"{prefix}_visible_{band}_recall", round(recall, 4))
        print(f"    {lo * 100:.0f}-{hi * 100:.0f} % visible: {n} rings, recall {recall:.3f}")
    if score.visibility:
        c = score.counts_visible(DIFFICULT_BELOW)
        result.add(f"{prefix}_f1_visible_over_25pct", round(c.f1, 4))
        print(f"    rings under 25 % visible as 'difficult': {c.summary()}")


def pipeline_fps(dets: dict[str, Detector], camera: CameraConfig, result: Result) -> None:
    cv2.setNumThreads(1)
    seed = TEST_SEED - 1
    while len((r := random_frame(np.random.default_rng(seed), camera.intrinsics)).boxes) < 5:
        seed -= 1  # a busy frame: localisation costs per ring
    frame = r.frame
    print(f"speed frame: 640x480, {len(r.boxes)} rings, one thread")
    for name, det in dets.items():
        for pre in (False, True):
            pipe = Pipeline(det, camera, PrefilterConfig(enabled=pre))
            ns = median_ns(lambda p=pipe: p.process(frame), number=20, repeats=7)
            key = f"fps_{name}{'_prefilter' if pre else ''}"
            result.add(key, round(per_second(ns), 1))
            parts = pipe.process(frame).timings_ms
            detail = ", ".join(f"{k} {v:.2f} ms" for k, v in parts.items())
            print(f"  {key}: {per_second(ns):.0f} frames/s ({detail})")
    loc = Localiser(camera)
    boxes = ClassicalDetector(camera=camera).detect(frame.color, frame.depth_m)
    ns = median_ns(lambda: loc.localise(boxes, frame.depth_m, None, frame.intrinsics), number=50)
    result.add("localise_us_per_frame", round(ns / 1e3, 1))


def simulator_test_set(frames: int, seed: int = 0) -> Path | None:
    """The simulator's test set, rendered once into runs/; None without the simulator."""
    try:
        from sim.dataset import SCENES_VERSION, DatasetConfig, write_dataset
    except ImportError as exc:
        print(f"bench.perception: no simulator ({exc}); using the numpy renderer")
        return None
    out = ROOT / "runs" / "bench-perception" / f"sim-seed{seed}-{frames}"
    done = out / "done"
    stamp = f"complete, scenes version {SCENES_VERSION}\n"
    if not done.is_file() or done.read_text() != stamp:
        # Not there, cut short, or rendered by code whose scenes differ: render it again.
        print(f"rendering the simulator test set into {out} ({frames} frames, seed {seed})")
        if out.exists():
            import shutil

            shutil.rmtree(out)
        out.mkdir(parents=True)
        write_dataset(DatasetConfig(frames=frames, seed=seed), out, progress=True)
        done.write_text(stamp)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.perception",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--sim-data", type=Path, help="a `pete-sim dataset` folder")
    parser.add_argument("--synthetic", action="store_true", help="the numpy renderer's frames")
    parser.add_argument("--frames", type=int, default=500, help="generated test frames (500)")
    parser.add_argument(
        "--real",
        type=Path,
        action="append",
        help="a YOLO folder of real labelled images (repeatable: scored per folder and pooled; "
        "default the shared BLRSAI set)",
    )
    parser.add_argument("--model", type=Path, help="CNN model (default jetson/models/ringnet.onnx)")
    parser.add_argument("--strict", action="store_true", help="exit 1 if a target is missed")
    args = parser.parse_args(argv)

    camera = CameraConfig()
    dets = detectors(camera, args.model)
    result = Result("perception")
    meta = None
    if "cnn" in dets:
        meta = json.loads(metadata_path(args.model or DEFAULT_DETECTOR).read_text())
        print(f"CNN model trained on: {', '.join(meta.get('trained_on', ['?']))}")

    if args.sim_data is None and not args.synthetic:
        args.sim_data = simulator_test_set(args.frames)
    if args.sim_data is not None:
        print(f"== simulator test set {args.sim_data}")
        prefix = "sim"
        ds = RingDataset(args.sim_data)
        if ds.meta is not None and "intrinsics" in ds.meta:
            camera = CameraConfig(Intrinsics.from_dict(ds.meta["intrinsics"]), camera.mount)
        scores = folder_scores(dets, camera, ds, prefilter=False)
    else:
        print(f"== synthetic test set: {args.frames} frames (numpy renderer, not the simulator)")
        prefix = "synthetic"
        scores = synthetic_scores(dets, camera, args.frames)
    for name, score in scores.items():
        print(f"  {name}: {score.counts.summary()}")
        for lo, hi, n, med, p90 in score.localisation_bands(BANDS):
            print(f"    {lo:.0f}-{hi:.0f} m: {n} rings, median {med * 100:.1f} cm, "
                  f"p90 {p90 * 100:.1f} cm")  # fmt: skip
        add_detection(result, f"{prefix}_{name}", score.counts)
        add_localisation(result, f"{prefix}_{name}", score)
        add_visibility(result, f"{prefix}_{name}", score)
    result.add(f"{prefix}_frames", scores[next(iter(scores))].frames)

    real = [p for p in (args.real or [SHARED_REAL]) if p.is_dir()]
    for p in sorted(set(args.real or [SHARED_REAL]) - set(real)):
        print(f"== real images: {p} is not there; skipped (pass --real DIR)")
    if real:
        real_images(dets, camera, real, meta, result)

    print("== speed")
    pipeline_fps(dets, camera, result)

    default = "cnn" if "cnn" in dets else "classical"
    result.target(f"{prefix}_{default}_f1", 0.95, ">=")
    result.target(f"{prefix}_{default}_loc_within_2m_median_m", 0.03, "<=")
    if real:
        result.target(f"real_{default}_f1", 0.85, ">=")
    result.target(f"fps_{default}", 60.0, ">=")
    print()
    result.report()
    return 1 if args.strict and not result.all_met else 0


if __name__ == "__main__":
    sys.exit(main())
