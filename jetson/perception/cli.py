"""The perception commands of `pete-jetson`: detect, detector {train,quantize,tune,eval,synth},
calibrate, record. jetson/cli.py registers them; heavy imports happen inside each command."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from jetson.errors import CameraConfigError
from jetson.perception.camera import CameraConfig
from protocol.cli_conventions import ProgressLine, add_no_progress, progress_wanted

DETECTORS = ("classical", "cnn")  # as jetson.perception.pipeline, without importing OpenCV

HELP = """\
  pete-jetson detect       run the ring pipeline on a source; annotated images + top-down plots
  pete-jetson detector     train / quantize / tune / eval the ring detector; synthetic datasets
  pete-jetson calibrate    checkerboard calibration -> camera config (K, distortion)
  pete-jetson record       record a camera source to disk (our recording format)
"""


def _camera(args: argparse.Namespace) -> CameraConfig:
    return CameraConfig.load(args.camera) if args.camera else CameraConfig()


def _add_pipeline_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--detector", choices=DETECTORS, default="cnn", help="ring detector")
    p.add_argument(
        "--model",
        type=Path,
        help="CNN weights, .onnx (default: the shipped jetson/models/ringnet.onnx)",
    )
    p.add_argument("--threshold", type=float, help="score threshold (default: the model's)")
    p.add_argument(
        "--prefilter",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="mask the image to the HSV window first (the original team's GRIP stage)",
    )
    p.add_argument("--camera", type=Path, help="camera config JSON (default: built-in D435)")


def _pipeline(args: argparse.Namespace, camera: CameraConfig):
    from jetson.perception.pipeline import Pipeline, make_detector
    from jetson.perception.prefilter import PrefilterConfig

    detector = make_detector(args.detector, camera, args.model, args.threshold)
    return Pipeline(detector, camera, PrefilterConfig(enabled=args.prefilter))


def cmd_detect(args: argparse.Namespace) -> int:
    import cv2

    from jetson.perception.annotate import draw_detections, top_down
    from jetson.perception.sources import open_source

    camera = _camera(args)
    pipeline = _pipeline(args, camera)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    writers: dict[str, cv2.VideoWriter] = {}
    if not args.video:
        (out / "annotated").mkdir(exist_ok=True)
        (out / "topdown").mkdir(exist_ok=True)
    n = 0
    total_ms = 0.0
    with (
        open_source(str(args.source), camera.intrinsics) as source,
        (out / "rings.jsonl").open("w") as log,
        ProgressLine(
            "pete-jetson detect",
            _frames_to_come(source, args.max_frames),
            "frames",
            enabled=progress_wanted(args.no_progress),
        ) as bar,
    ):
        for frame in source:
            if args.max_frames is not None and n >= args.max_frames:
                break
            result = pipeline.process(frame)
            total_ms += sum(result.timings_ms.values())
            annotated = draw_detections(frame.color, result.detections, result.rings)
            plan = top_down(result.rings, camera, title=f"frame {frame.index}")
            if args.video:
                for name, img in (("annotated", annotated), ("topdown", plan)):
                    if name not in writers:
                        h, w = img.shape[:2]
                        fourcc = cv2.VideoWriter.fourcc(*"mp4v")
                        writers[name] = cv2.VideoWriter(
                            str(out / f"{name}.mp4"), fourcc, args.fps, (w, h)
                        )
                    writers[name].write(img)
            else:
                cv2.imwrite(str(out / "annotated" / f"{n:06d}.png"), annotated)
                cv2.imwrite(str(out / "topdown" / f"{n:06d}.png"), plan)
            record = {
                "index": frame.index,
                "timestamp_s": frame.timestamp_s,
                "detections": [
                    [round(v, 1) for v in (d.x0, d.y0, d.x1, d.y1)] + [round(d.score, 3)]
                    for d in result.detections
                ],
                "rings_robot_xy": np.round(result.rings_robot_xy, 4).tolist(),
            }
            log.write(json.dumps(record) + "\n")
            n += 1
            bar.update()
    for w in writers.values():
        w.release()
    if n == 0:
        print(f"{args.source}: no frames")
        return 1
    print(
        f"{n} frames, {total_ms / n:.1f} ms per frame in the pipeline; wrote {out}/"
        f"{'annotated.mp4, topdown.mp4' if args.video else 'annotated/, topdown/'}, rings.jsonl"
    )
    return 0


def _frames_to_come(source: object, max_frames: int | None) -> int | None:
    """How many frames detect will read, where that is known (a folder or a recording has a
    length; a camera or a stream does not)."""
    try:
        known: int | None = len(source)  # type: ignore[arg-type]
    except TypeError:
        known = None
    if max_frames is None:
        return known
    return max_frames if known is None else min(known, max_frames)


def _patch(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise CameraConfigError(
            f"--patch is WIDTHxHEIGHT in pixels, e.g. 192x160; got {text!r}"
        ) from exc
    if w < 16 or h < 16 or w % 16 or h % 16:
        raise CameraConfigError(f"--patch sides must be multiples of 16, at least 16; got {text!r}")
    return w, h


def cmd_train(args: argparse.Namespace) -> int:
    try:
        from jetson.perception.cnn.train import TrainConfig, train
    except ImportError as exc:
        raise CameraConfigError(
            f"training needs torch ({exc}); install the sim extra: pip install "
            "'pacman-pete[sim]' (the Jetson only runs models; train on a desktop)"
        ) from exc
    cfg = TrainConfig(
        data=list(args.data or []),
        val_data=list(args.val or []),
        synthetic=args.synthetic,
        holdout=args.holdout,
        steps=args.steps,
        batch=args.batch,
        seed=args.seed,
        threads=args.threads,
        width=args.width,
        blocks=args.blocks,
        giou_weight=args.giou,
        strong_cast=args.strong_cast,
        input_long_side=args.input_long_side,
        patch=_patch(args.patch),
        init=args.init,
        lr=args.lr,
    )
    train(cfg, args.out)
    return 0


def cmd_quantize(args: argparse.Namespace) -> int:
    from jetson.perception.cnn.quantize import quantize

    report = quantize(args.model, list(args.calib), args.out, args.frames, args.all_int8)
    print(
        f"wrote {report.out} (int8, calibrated on {report.calibration_images} images): "
        f"{report.float_ms:.1f} ms a 640x480 frame as float, {report.int8_ms:.1f} ms as int8 "
        "(one thread). int8 moves the scores a little: choose its threshold again at its "
        f"size (`pete-jetson detector tune --model {report.out} --val DIR --sizes N --write`, "
        "N its input long side) and check it with `pete-jetson detector eval --model "
        f"{report.out} --images DIR`"
    )
    return 0


def cmd_tune(args: argparse.Namespace) -> int:
    from jetson.perception.cnn.tune import calibration_note, format_table, tune, write_choice

    try:
        sizes = tuple(int(v) for v in args.sizes.split(","))
        thresholds = tuple(float(v) for v in args.thresholds.split(","))
    except ValueError as exc:
        raise CameraConfigError(
            f"--sizes and --thresholds are comma-separated numbers: {exc}"
        ) from exc
    tuning = tune(args.model, list(args.val), sizes, thresholds)
    print("mean F1 over the folders' held-out images, by input long side and threshold:")
    print(format_table(tuning))
    print(
        f"best: input long side {tuning.input_long_side}, threshold {tuning.score_threshold} "
        f"(mean F1 {tuning.mean_f1:.3f})"
    )
    note = calibration_note(args.model, tuning.input_long_side)
    if note:
        print(note)
    if args.write:
        write_choice(args.model, tuning)
        print(f"written to {args.model.with_suffix('.json')}")
    return 0


def cmd_eval(args: argparse.Namespace) -> int:
    from jetson.autonomy.camera import CameraMount
    from jetson.perception.classical import ClassicalDetector
    from jetson.perception.cnn.runtime import CnnDetector
    from jetson.perception.dataset import RingDataset
    from jetson.perception.evaluate import heldout_of, score_dataset, trained_on

    camera = _camera(args)
    dataset = RingDataset(args.images)
    if note := dataset.skipped_note():
        print(note)
    known_camera = args.camera is not None
    if dataset.meta is not None and "mount" in dataset.meta and not args.camera:
        camera = CameraConfig(camera.intrinsics, CameraMount.from_dict(dataset.meta["mount"]))
        known_camera = True
    elif dataset.meta is not None and dataset.meta.get("mounts") and not args.camera:
        # A simulator folder with several robots: the first robot's mount sets the detector's
        # ring-size prior; localisation uses each frame's own mount (frames.jsonl).
        first = next(iter(dataset.meta["mounts"].values()))
        camera = CameraConfig(camera.intrinsics, CameraMount.from_dict(first))
        known_camera = True
    pipeline = _pipeline(args, camera)
    if not known_camera and isinstance(pipeline.detector, ClassicalDetector):
        # Photos from an unknown camera: the ring-size prior of the robot's mount would mislead.
        pipeline.detector = ClassicalDetector()
        print("no camera for these images (no dataset.json, no --camera): no ring-size prior")
    if isinstance(pipeline.detector, CnnDetector):
        meta = pipeline.detector.info.extra
        held = heldout_of(meta, args.images)
        if held is not None and not args.all_images:
            dataset = dataset.subset(held)
            print(
                f"the model trained on this folder: scoring the {len(dataset)} images it held out"
            )
        elif trained_on(meta, args.images):
            print("warning: the model was trained on these images; this score flatters it")
    t0 = time.perf_counter()
    n = len(dataset) if args.limit is None else min(args.limit, len(dataset))
    with ProgressLine(
        "pete-jetson detector eval", n, "images", enabled=progress_wanted(args.no_progress)
    ) as bar:
        score = score_dataset(
            pipeline,
            dataset,
            args.iou,
            args.limit,
            progress=lambda done, total: bar.update(done - bar.count),
        )
    dt = time.perf_counter() - t0
    c = score.counts
    pre = "with" if args.prefilter else "without"
    print(f"{args.detector} detector, {pre} pre-filter, IoU >= {args.iou}, {score.frames} images")
    print(f"precision {c.precision:.3f}")
    print(f"recall    {c.recall:.3f}")
    print(f"F1        {c.f1:.3f}")
    print(f"(TP {c.tp}, FP {c.fp}, FN {c.fn}; {dt / max(1, score.frames) * 1e3:.1f} ms per image)")
    for lo, hi, count, med, p90 in score.localisation_bands():
        print(
            f"localisation {lo:.0f}-{hi:.0f} m: {count} rings, median error {med * 100:.1f} cm, "
            f"p90 {p90 * 100:.1f} cm"
        )
    for lo, hi, count, recall in score.recall_by_visibility():
        print(f"{lo:.0%}-{hi:.0%} of the ring visible: {count} rings, recall {recall:.3f}")
    if score.unplaced:
        print(f"{score.unplaced} matched rings could not be placed (no valid depth)")
    return 0


def cmd_synth(args: argparse.Namespace) -> int:
    from jetson.autonomy.camera import Intrinsics
    from jetson.perception.dataset import write_meta, write_sample
    from jetson.perception.synthetic import random_frame

    camera = _camera(args)
    intr = camera.intrinsics
    if (args.width, args.height) != (intr.width, intr.height):
        intr = intr.scaled(args.width, args.height)
    if args.frames < 1:
        raise CameraConfigError("--frames must be at least 1")
    out: Path = args.out
    write_meta(
        out,
        {
            "source": "jetson.perception.synthetic",
            "seed": args.seed,
            "frames": args.frames,
            "intrinsics": intr.to_dict(),
            "mount": camera.mount.to_dict(),
        },
    )
    rings = 0
    for k in range(args.frames):
        rng = np.random.default_rng(args.seed + k)
        r = random_frame(rng, Intrinsics.from_dict(intr.to_dict()), camera.mount, index=k)
        write_sample(out, f"{args.seed + k:08d}", r.frame.color, r.boxes, r.frame.depth_m,
                     r.rings_robot_xy)  # fmt: skip
        rings += len(r.boxes)
    print(f"wrote {args.frames} frames with {rings} labelled rings to {out}")
    return 0


def cmd_calibrate(args: argparse.Namespace) -> int:
    from jetson.perception.calibrate import calibrate_folder, parse_board

    board = parse_board(args.board)
    if not args.square_mm > 0:
        raise CameraConfigError(f"--square-mm must be positive, got {args.square_mm}")
    cal = calibrate_folder(args.images, board, args.square_mm / 1000.0)
    i = cal.intrinsics
    print(f"board found in {len(cal.per_image_rms_px)} images; skipped: {cal.skipped or 'none'}")
    print(f"image size {i.width}x{i.height}")
    print(f"fx {i.fx:.3f}  fy {i.fy:.3f}  cx {i.cx:.3f}  cy {i.cy:.3f}")
    print("dist (k1 k2 p1 p2 k3) " + " ".join(f"{d:.5g}" for d in i.dist))
    print(f"reprojection error (RMS) {cal.rms_px:.4f} px")
    worst = sorted(cal.per_image_rms_px.items(), key=lambda kv: -kv[1])[:3]
    print("worst images: " + ", ".join(f"{n} {e:.3f} px" for n, e in worst))
    out: Path = args.out
    mount = CameraConfig.load(out).mount if out.is_file() else CameraConfig().mount
    CameraConfig(i, mount, cal.summary()).save(out)
    print(f"wrote {out}")
    return 0


def cmd_record(args: argparse.Namespace) -> int:
    from jetson.perception.sources import open_source
    from jetson.perception.sources.recording import Recorder

    camera = _camera(args)
    n = 0
    with (
        open_source(args.source, camera.intrinsics) as source,
        Recorder(args.out, source=args.source) as rec,
    ):
        for frame in source:
            rec.write(frame)
            n += 1
            if args.frames is not None and n >= args.frames:
                break
    print(f"recorded {n} frames to {args.out}")
    return 0 if n else 1


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "detect",
        help="run detection + localisation on a source, write annotated images and plots",
        description="SOURCE: realsense[:SERIAL], a .bag, a recording or image folder, a "
        "video, or unix:PATH / tcp:HOST:PORT for a frame stream.",
    )
    p.add_argument("--source", required=True, help="what to read (see above)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    _add_pipeline_args(p)
    p.add_argument("--max-frames", type=int, help="stop after this many frames")
    p.add_argument("--video", action="store_true", help="write .mp4 videos instead of PNGs")
    p.add_argument("--fps", type=float, default=30.0, help="frame rate of --video output")
    add_no_progress(p)
    p.set_defaults(func=cmd_detect)

    d = sub.add_parser("detector", help="train or evaluate the ring detector")
    dsub = d.add_subparsers(dest="detector_command", required=True, metavar="ACTION")
    t = dsub.add_parser(
        "train",
        help="train the CNN from scratch (needs torch)",
        description="Train RingNet from YOLO-format folders (images/ + labels/) and/or "
        "synthetic frames; writes OUT (.onnx), its .json metadata and .pt weights.",
    )
    t.add_argument("--data", type=Path, action="append", help="a dataset folder (repeatable)")
    t.add_argument("--val", type=Path, action="append", help="a validation folder (repeatable)")
    t.add_argument("--synthetic", type=int, default=0, help="synthetic frames to add")
    t.add_argument(
        "--holdout",
        type=float,
        default=0.0,
        help="fraction of each --data folder's source images to hold out for validation",
    )
    t.add_argument("--out", type=Path, required=True, help="the .onnx file to write")
    t.add_argument("--steps", type=int, default=1500, help="optimiser steps")
    t.add_argument("--batch", type=int, default=16, help="training crops per step")
    t.add_argument("--width", type=int, default=16, help="channels of the first stage")
    t.add_argument(
        "--blocks",
        type=int,
        default=1,
        help="3x3 convolutions after the down-sampling in the two deepest stages; 2 widens "
        "the receptive field for ~45 %% more network time",
    )
    t.add_argument(
        "--giou",
        type=float,
        default=0.0,
        help="weight of a GIoU loss on the boxes, 0 for L1 on log sizes only; a match needs "
        "IoU >= 0.5, which L1 on sizes does not aim at",
    )
    t.add_argument(
        "--strong-cast",
        type=float,
        default=0.0,
        help="share of training samples lit by strongly coloured light, one colour channel "
        "down to a sixth of the others; for photos taken under coloured stage or LED light",
    )
    t.add_argument(
        "--input-long-side",
        type=int,
        default=320,
        help="the long side frames are resized to before the network; larger finds "
        "smaller rings and costs frame rate",
    )
    t.add_argument(
        "--patch",
        default="192x160",
        help="training crop WIDTHxHEIGHT at the input scale; a model trained at a "
        "larger --input-long-side needs a larger patch to see as much of the scene around piles",
    )
    t.add_argument(
        "--init",
        type=Path,
        help="start from these weights instead of from scratch (a .pt detector train wrote, "
        "e.g. jetson/models/ringnet.pt): fine-tune the shipped detector on your own labelled "
        "photos",
    )
    t.add_argument("--lr", type=float, default=3e-3, help="peak learning rate")
    t.add_argument("--seed", type=int, default=0, help="random seed")
    t.add_argument("--threads", type=int, default=2, help="torch threads")
    t.set_defaults(func=cmd_train)
    q = dsub.add_parser(
        "quantize",
        help="an int8 copy of a trained model: about twice as fast on a CPU",
        description="Static int8 quantization (onnxruntime, QDQ format): weights int8 per "
        "channel, activations uint8 with ranges measured on calibration images (never the "
        "images the model held out); the first and last convolutions stay float. Writes OUT "
        "and its .json; needs the onnx package.",
    )
    q.add_argument("--model", type=Path, required=True, help="the float .onnx detector train wrote")
    q.add_argument(
        "--calib", type=Path, action="append", required=True, help="an image folder (repeatable)"
    )
    q.add_argument("--frames", type=int, default=96, help="calibration images in all")
    q.add_argument("--out", type=Path, required=True, help="the int8 .onnx to write")
    q.add_argument(
        "--all-int8",
        action="store_true",
        help="quantize the first and last convolutions too (kept float by default: the image's "
        "fine colour steps and the output's scores suffer most, for little time)",
    )
    q.set_defaults(func=cmd_quantize)
    u = dsub.add_parser(
        "tune",
        help="choose the model's input size and threshold on labelled held-out images",
        description="Score the model at several input sizes and thresholds on each --val "
        "folder (only the images it held out, when it trained on the folder) and report the "
        "pair with the best mean F1; --write stores it in the model's .json. A larger input "
        "finds smaller and more hidden rings and costs frame rate.",
    )
    u.add_argument("--model", type=Path, required=True, help="the .onnx to tune")
    u.add_argument(
        "--val", type=Path, action="append", required=True, help="a labelled folder (repeatable)"
    )
    u.add_argument("--sizes", default="480,512,528,544,560,576,608,640", help="input long sides")
    u.add_argument("--thresholds", default="0.3,0.35,0.4,0.45,0.5,0.55,0.6", help="scores")
    u.add_argument("--write", action="store_true", help="store the choice in the model's .json")
    u.set_defaults(func=cmd_tune)
    e = dsub.add_parser(
        "eval",
        help="precision, recall and F1 on a dataset folder",
        description="Score a detector on a YOLO-format folder (images/ + labels/); when the "
        "folder also has depth/ and truth/, localisation error by distance too.",
    )
    e.add_argument("--images", type=Path, required=True, help="the dataset folder")
    _add_pipeline_args(e)
    e.add_argument("--iou", type=float, default=0.5, help="IoU for a match")
    e.add_argument("--limit", type=int, help="score only the first N images")
    e.add_argument(
        "--all-images",
        action="store_true",
        help="score every image even if the model trained on some (default: held-out only)",
    )
    add_no_progress(e)
    e.set_defaults(func=cmd_eval)
    s = dsub.add_parser(
        "synth",
        help="write synthetic frames as a dataset folder (images, labels, depth, truth)",
    )
    s.add_argument("--frames", type=int, required=True, help="how many frames")
    s.add_argument("--out", type=Path, required=True, help="the dataset folder to write")
    s.add_argument("--seed", type=int, default=0, help="frame k uses seed SEED + k")
    s.add_argument("--width", type=int, default=640, help="image width, pixels")
    s.add_argument("--height", type=int, default=480, help="image height, pixels")
    s.add_argument("--camera", type=Path, help="camera config JSON (default: built-in D435)")
    s.set_defaults(func=cmd_synth)

    c = sub.add_parser(
        "calibrate",
        help="checkerboard calibration: K, distortion, reprojection error -> camera config",
    )
    c.add_argument("--images", type=Path, required=True, help="folder of checkerboard images")
    c.add_argument("--board", required=True, help="INNER corners as COLSxROWS, e.g. 9x6")
    c.add_argument("--square-mm", type=float, required=True, help="square side, millimetres")
    c.add_argument(
        "--out",
        type=Path,
        default=Path("camera.json"),
        help="the camera config to write (the mount already in it is kept)",
    )
    c.set_defaults(func=cmd_calibrate)

    r = sub.add_parser("record", help="record a source to disk (colour PNG + 16-bit depth)")
    r.add_argument("--source", default="realsense", help="what to record")
    r.add_argument("--out", type=Path, required=True, help="a new folder")
    r.add_argument("--frames", type=int, help="stop after this many frames")
    r.add_argument("--camera", type=Path, help="camera config for sources without intrinsics")
    r.set_defaults(func=cmd_record)
