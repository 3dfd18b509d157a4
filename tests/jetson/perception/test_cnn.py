"""The CNN detector: ONNX export agrees with torch, decoding, errors, a tiny training run."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from jetson.errors import DatasetError, ModelError
from jetson.perception.cnn.augment import AugmentConfig, augment, photometric, random_patch
from jetson.perception.cnn.runtime import (
    CnnDetector,
    ModelInfo,
    decode,
    input_size,
    metadata_path,
    to_input,
)
from jetson.perception.detection import Detection

torch = pytest.importorskip("torch")
ort = pytest.importorskip("onnxruntime")

from jetson.perception.cnn.model import STRIDE, ExportWrapper, RingNet  # noqa: E402
from jetson.perception.cnn.train import (  # noqa: E402
    Source,
    TrainConfig,
    evaluate,
    giou_loss,
    ignore_mask,
    loss_fn,
    make_targets,
    train,
)


@pytest.fixture(scope="module")
def tiny_model(
    tmp_path_factory: pytest.TempPathFactory, untrained_ringnet: Callable[..., tuple[RingNet, Path]]
) -> tuple[RingNet, Path]:
    path = tmp_path_factory.mktemp("model") / "tiny.onnx"
    # blocks=2: dilations 2 and 4 in the deepest stage, which export must carry too
    return untrained_ringnet(
        path, seed=0, width=4, blocks=2, input_long_side=128, score_threshold=0.0
    )


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # the legacy exporter, on purpose
def test_onnx_forward_agrees_with_torch(tiny_model: tuple[RingNet, Path], tmp_path: Path) -> None:
    net, _ = tiny_model
    raw_path = tmp_path / "raw.onnx"
    torch.onnx.export(
        net, (torch.zeros(1, 3, 96, 128),), str(raw_path), input_names=["rgb"],
        output_names=["raw"], dynamic_axes={"rgb": {0: "n", 2: "h", 3: "w"}}, opset_version=17,
        dynamo=False,
    )  # fmt: skip
    session = ort.InferenceSession(str(raw_path), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    # Two sizes: the graph's height and width are dynamic.
    for h, w in ((96, 128), (160, 224)):
        x = rng.random((2, 3, h, w), dtype=np.float32)
        with torch.no_grad():
            want = net(torch.from_numpy(x)).numpy()
        (got,) = session.run(None, {"rgb": x})
        assert got.shape == (2, 5, h // STRIDE, w // STRIDE)
        np.testing.assert_allclose(got, want, atol=1e-4, rtol=0)


def test_exported_detector_graph_agrees_with_torch(tiny_model: tuple[RingNet, Path]) -> None:
    net, path = tiny_model
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    x = np.random.default_rng(3).random((1, 3, 96, 128), dtype=np.float32)
    with torch.no_grad():
        want_peaks, want_boxes = (t.numpy() for t in ExportWrapper(net)(torch.from_numpy(x)))
        heat = torch.sigmoid(net(torch.from_numpy(x))[:, 0:1])
        pooled = torch.nn.functional.max_pool2d(heat, 3, 1, 1)
    got_peaks, got_boxes = session.run(None, {"rgb": x})
    np.testing.assert_allclose(got_boxes, want_boxes, atol=1e-4, rtol=0)
    # Whether a cell is a 3x3 maximum can flip between runtimes only where its neighbour is
    # within rounding of it; everywhere else the peaks must agree.
    second = torch.nn.functional.max_pool2d(
        torch.where(heat == pooled, torch.full_like(heat, -1.0), heat), 3, 1, 1
    )
    clear = ((heat - second).abs() > 1e-4).numpy() | (want_peaks == 0) & (got_peaks == 0)
    assert clear.mean() > 0.5
    np.testing.assert_allclose(got_peaks[clear], want_peaks[clear], atol=1e-4, rtol=0)


def test_peaks_are_local_maxima_only(tiny_model: tuple[RingNet, Path]) -> None:
    _, path = tiny_model
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    x = np.random.default_rng(1).random((1, 3, 96, 128), dtype=np.float32)
    peaks = session.run(None, {"rgb": x})[0][0, 0]
    nz = np.argwhere(peaks > 0)
    assert len(nz) > 0
    for y, x_ in nz:
        window = peaks[max(0, y - 1) : y + 2, max(0, x_ - 1) : x_ + 2]
        assert peaks[y, x_] == window.max()


def test_decode_turns_cells_into_boxes() -> None:
    peaks = np.zeros((1, 6, 8), np.float32)
    boxes = np.zeros((4, 6, 8), np.float32)
    peaks[0, 2, 3] = 0.9
    boxes[:, 2, 3] = (0.5, 0.25, np.log(2.0), np.log(1.0))  # offset, log(w / 4), log(h / 4)
    peaks[0, 5, 7] = 0.1  # below the threshold
    dets = decode(peaks, boxes, STRIDE, 0.3, (2.0, 2.0))
    assert len(dets) == 1
    d = dets[0]
    # Centre (3.5, 2.25) cells = (14, 9) px at the input; 8 x 4 px; then scaled by 2.
    assert (d.x0, d.y0, d.x1, d.y1) == pytest.approx((20.0, 14.0, 36.0, 22.0))
    assert d.score == pytest.approx(0.9)


def test_input_sizes_are_multiples_of_16() -> None:
    assert input_size(640, 480, 320) == (320, 240)
    assert input_size(416, 416, 320) == (320, 320)
    w, h = input_size(1280, 720, 320)
    assert w % 16 == 0 and h % 16 == 0 and w == 320
    x = to_input(np.zeros((480, 640, 3), np.uint8), (320, 240))
    assert x.shape == (1, 3, 240, 320) and x.dtype == np.float32


def test_cnn_detector_runs_on_a_frame(tiny_model: tuple[RingNet, Path]) -> None:
    _, path = tiny_model
    det = CnnDetector(path, score_threshold=0.0)
    img = np.random.default_rng(2).integers(0, 256, (240, 320, 3), dtype=np.uint8)
    dets = det.detect(img)
    assert len(dets) > 0
    assert all(0.0 <= d.score <= 1.0 for d in dets)
    assert [d.score for d in dets] == sorted((d.score for d in dets), reverse=True)


def test_missing_or_broken_models_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match=r"does not exist.*detector train"):
        CnnDetector(tmp_path / "none.onnx")
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a model")
    with pytest.raises(ModelError, match=r"metadata .* is missing"):
        CnnDetector(bad)
    metadata_path(bad).write_text(json.dumps({"format": "pete-ringnet", "version": 1,
                                              "stride": 4, "input_long_side": 320,
                                              "score_threshold": 0.4}))  # fmt: skip
    with pytest.raises(ModelError, match="not a loadable ONNX model"):
        CnnDetector(bad)
    meta = json.loads(metadata_path(bad).read_text())
    metadata_path(bad).write_text(json.dumps(meta | {"max_upscale": 0.5}))
    with pytest.raises(ModelError, match="max_upscale must be >= 1"):
        CnnDetector(bad)


def test_small_frames_are_blown_up_at_most_max_upscale_times() -> None:
    info = ModelInfo(input_long_side=704, max_upscale=2.25)
    assert info.input_size(640, 480) == (704, 528)  # the camera: the input size as tuned
    assert info.input_size(416, 416) == (704, 704)  # photos: 1.7 times
    assert info.input_size(240, 180) == (544, 400)  # the full-stack match's frames: 2.25, not 2.9
    assert ModelInfo(input_long_side=704, max_upscale=4.0).input_size(240, 180) == (704, 528)


def test_targets_put_each_ring_at_its_centre_cell() -> None:
    heat, reg, mask = make_targets([np.array([[10.0, 20.0, 30.0, 28.0]])], 64, 48)
    assert heat.shape == (1, 1, 12, 16)
    # Centre (20, 24) px -> cell (5, 6), offset (0, 0); size (20, 8) px = (5, 2) cells.
    assert float(heat[0, 0, 6, 5]) == 1.0 and float(mask.sum()) == 1.0
    assert reg[0, :, 6, 5].tolist() == pytest.approx([0.0, 0.0, np.log(5.0), np.log(2.0)])
    assert float(heat[0, 0, 6, 7]) < 1.0
    raw = torch.zeros(1, 5, 12, 16, requires_grad=True)
    loss, parts = loss_fn(raw, heat, reg, mask)
    loss.backward()
    assert float(loss.detach()) > 0 and set(parts) == {"focal", "offset", "size"}


def test_augmentation_moves_boxes_with_the_image() -> None:
    rng = np.random.default_rng(0)
    img = np.zeros((240, 320, 3), np.uint8)
    img[100:140, 150:200] = 255
    box = np.array([[150.0, 100.0, 200.0, 140.0]])
    cfg = AugmentConfig()
    for _ in range(10):
        patch, b, ignore = random_patch(rng, img, box, (192, 160), cfg, ignore=box)
        assert patch.shape == (160, 192, 3)
        for x0, y0, x1, y1 in np.concatenate([b, ignore]):
            inner = patch[int(y0) + 2 : int(y1) - 2, int(x0) + 2 : int(x1) - 2]
            if inner.size:
                assert inner.mean() > 200  # the white block is where its box says
    out, _, _ = augment(rng, img, box, (192, 160), cfg)
    assert out.shape == (160, 192, 3) and out.dtype == np.uint8


def test_strongly_coloured_light_reaches_the_casts_of_real_photos() -> None:
    # A grey scene; the BLRSAI photos include rooms lit so that one channel's mean is under a
    # fifth of the image's average. The strong cast must produce such images, keep the mean
    # brightness, and leave the mild-cast images alone when it is off.
    img = np.full((64, 64, 3), 128, np.uint8)
    quiet = dict(noise_p=0.0, blur_p=0.0, motion_blur_p=0.0, jpeg_p=0.0, prefilter_p=0.0)
    quiet.update(brightness=(1.0, 1.0), contrast=(1.0, 1.0), saturation=(1.0, 1.0))
    strong = replace(AugmentConfig(), strong_cast_p=1.0, **quiet)  # type: ignore[arg-type]
    rng = np.random.default_rng(0)
    spreads, means = [], []
    for _ in range(40):
        m = photometric(rng, img, strong).reshape(-1, 3).mean(axis=0)
        spreads.append(m.min() / m.mean())
        means.append(m.mean())
    assert min(spreads) < 0.3  # some draws take a channel below a third of the average
    assert abs(np.median(means) - 128) < 15  # the image's brightness is kept (up to clipping)
    mild = replace(strong, strong_cast_p=0.0)
    for _ in range(20):
        m = photometric(rng, img, mild).reshape(-1, 3).mean(axis=0)
        assert m.min() / m.mean() > 0.8


def test_a_ring_cut_by_the_patch_edge_is_a_ring_or_ignored_never_background() -> None:
    # Patches of a 192x160 image at scale 1 are the image itself, shifted by nothing: the
    # boxes below are cut by the image's edge as a crop would cut them. A cut ring's box is the
    # part of its ellipse inside the patch, as the datasets label rings the frame cuts.
    img = np.zeros((160, 192, 3), np.uint8)
    boxes = np.array(
        [
            [-30.0, 50.0, 10.0, 70.0],  # a quarter left, 10 wide: still a ring
            [186.0, 50.0, 226.0, 70.0],  # 6 px of the ellipse's side left: still a ring
            [50.0, -18.0, 90.0, 2.0],  # 2 px high: ignored
            [100.0, 156.0, 116.0, 170.0],  # 4 px of its top left, 14.5 wide: a ring
            [140.0, 157.0, 150.0, 167.0],  # 3x9 px left: ignored
            [60.0, 60.0, 64.0, 64.0],  # whole, 4x4 = 16 px: the dataset labelled it, kept
        ]
    )
    cfg = replace(AugmentConfig(), scale_range=(1.0, 1.0), aspect_jitter=0.0, flip=False)
    _, b, ignore = random_patch(np.random.default_rng(0), img, boxes, (192, 160), cfg)
    # Centre 10 px outside: the chord at the edge is 2 * 10 * sqrt(1 - 0.5^2) high.
    h1 = 10 * np.sqrt(0.75)
    h2 = 10 * np.sqrt(1 - 0.7**2)  # centre 14 px past the right edge, half-width 20
    w4 = 8 * np.sqrt(1 - (3 / 7) ** 2)  # centre 3 px below the bottom, half-height 7
    w5 = 5 * np.sqrt(1 - 0.4**2)
    assert np.allclose(
        b,
        [
            [0.0, 60 - h1, 10.0, 60 + h1],
            [186.0, 60 - h2, 192.0, 60 + h2],
            [108 - w4, 156.0, 108 + w4, 160.0],
            [60.0, 60.0, 64.0, 64.0],
        ],
    )
    assert np.allclose(ignore, [[58.0, 0.0, 82.0, 2.0], [145 - w5, 157.0, 145 + w5, 160.0]])
    # Flipped, the ignore boxes move with the image.
    cfg = replace(cfg, flip=True)
    rng = np.random.default_rng(0)
    while True:
        _, b, ignore = random_patch(rng, img, boxes, (192, 160), cfg)
        if b[0][0] > 100:  # this draw flipped
            break
    assert np.allclose(ignore, [[110.0, 0.0, 134.0, 2.0], [47 - w5, 157.0, 47 + w5, 160.0]])


def test_ignore_regions_cost_nothing_and_the_rest_of_the_background_does() -> None:
    heat, reg, mask = make_targets([np.array([[10.0, 10.0, 30.0, 30.0]])], 64, 48)
    ignore = ignore_mask([np.array([[40.0, 20.0, 52.0, 31.0]])], 64, 48)
    # Cells 10-12 across (x 40-52 px), rows 5-7 (y 20-31 px, the last cell only touched).
    assert ignore[0, 0].nonzero().tolist() == [[r, c] for r in (5, 6, 7) for c in (10, 11, 12)]
    raw = torch.full((1, 5, 12, 16), -8.0)
    raw[0, 0, 5, 5] = 8.0  # the ring, found
    base, _ = loss_fn(raw, heat, reg, mask, ignore=ignore)
    inside, outside = raw.clone(), raw.clone()
    inside[0, 0, 6, 11] = 8.0  # a detection in the ignore region
    outside[0, 0, 2, 11] = 8.0  # and one on plain background
    in_loss, _ = loss_fn(inside, heat, reg, mask, ignore=ignore)
    out_loss, _ = loss_fn(outside, heat, reg, mask, ignore=ignore)
    assert float(in_loss) == pytest.approx(float(base))
    assert float(out_loss) > float(base) + 5.0
    # Without the mask the same region is background.
    plain, _ = loss_fn(inside, heat, reg, mask)
    assert float(plain) > float(base) + 5.0


def test_giou_loss_by_hand() -> None:
    box = torch.tensor([[0.5, 0.5, 2.0, 2.0]])  # centre x, centre y, width, height
    assert float(giou_loss(box, box)) == pytest.approx(0.0)
    # The same centre, half the size: IoU 1/4 and the hull is the big box.
    assert float(giou_loss(box, torch.tensor([[0.5, 0.5, 1.0, 1.0]]))) == pytest.approx(0.75)
    # Apart: IoU 0 and an empty share of the hull, so the loss exceeds 1 and still has a slope.
    far = torch.tensor([[4.5, 0.5, 2.0, 2.0]], requires_grad=True)
    loss = giou_loss(box, far)
    assert float(loss.detach()) == pytest.approx(1 + (12 - 8) / 12)
    loss.backward()
    assert far.grad is not None and float(far.grad[0, 0]) > 0  # moving closer lowers it


def test_giou_term_scores_a_box_of_the_wrong_shape() -> None:
    # One ring; the prediction has its centre right and the log sizes off by +-0.5: L1 on the
    # sizes cannot tell a box too tall from one too wide and short, and both are not a match.
    heat, reg, mask = make_targets([np.array([[42.0, 42.0, 74.0, 74.0]])], 128, 96)
    raw = torch.zeros(1, 5, 24, 32)
    raw[:, 0] = -10.0
    iy, ix = 14, 14
    raw[0, 0, iy, ix] = 10.0
    assert reg[0, 0:2, iy, ix].tolist() == [0.5, 0.5]  # the ring's centre is mid-cell
    raw[0, 1:3, iy, ix] = 0.0  # sigmoid 0.5: right
    raw[0, 3:5, iy, ix] = reg[0, 2:4, iy, ix] + torch.tensor([0.5, -0.5])
    plain, parts = loss_fn(raw, heat, reg, mask)
    with_giou, parts_g = loss_fn(raw, heat, reg, mask, giou_weight=1.0)
    assert "giou" not in parts and parts_g["giou"] > 0.2
    assert float(with_giou) == pytest.approx(float(plain) + parts_g["giou"], rel=1e-5)


def test_validation_counts_a_detected_ignore_region_as_neither_hit_nor_false_alarm() -> None:
    class Fixed:
        threshold = 0.0

        def detect(self, _: object) -> list[Detection]:
            return [
                Detection(10, 10, 30, 30, 0.9),  # the ring
                Detection(50, 10, 70, 30, 0.8),  # the ignore region
                Detection(50, 50, 70, 70, 0.7),  # nothing
            ]

    image = np.zeros((96, 96, 3), np.uint8)
    truth, ignore = np.array([[10.0, 10, 30, 30]]), np.array([[50.0, 10, 70, 30]])
    counts = evaluate(Fixed(), Source("s", [image], [truth], [ignore]), [0.5, 0.75])  # type: ignore[arg-type]
    assert (counts[0.5].tp, counts[0.5].fp, counts[0.5].fn) == (1, 1, 0)
    assert (counts[0.75].tp, counts[0.75].fp, counts[0.75].fn) == (1, 0, 0)
    plain = evaluate(Fixed(), Source("s", [image], [truth]), [0.5])  # type: ignore[arg-type]
    assert (plain[0.5].tp, plain[0.5].fp) == (1, 2)


def test_training_runs_end_to_end_and_writes_a_usable_model(tmp_path: Path) -> None:
    cfg = TrainConfig(
        synthetic=3, synthetic_val=2, steps=2, batch=2, width=4, blocks=2, giou_weight=1.0,
        threads=1,
    )  # fmt: skip
    out = tmp_path / "m.onnx"
    meta = train(cfg, out, log=lambda _: None)
    assert out.is_file() and out.with_suffix(".pt").is_file()
    saved = json.loads(metadata_path(out).read_text())
    assert saved["trained_on"] == meta["trained_on"] and "validation" in saved
    assert saved["score_threshold"] == meta["score_threshold"]
    assert saved["blocks"] == 2 and saved["training"]["giou_weight"] == 1.0
    CnnDetector(out).detect(np.zeros((240, 320, 3), np.uint8))
    with pytest.raises(DatasetError, match="nothing to train on"):
        train(TrainConfig(), out)


def test_training_names_an_empty_label_box_once(tmp_path: Path) -> None:
    import cv2

    folder = tmp_path / "photos"
    (folder / "images").mkdir(parents=True)
    (folder / "labels").mkdir()
    for k in range(3):
        cv2.imwrite(str(folder / "images" / f"p{k}.png"), np.zeros((48, 64, 3), np.uint8))
        (folder / "labels" / f"p{k}.txt").write_text("0 0.5 0.5 0.25 0.25\n")
    (folder / "labels" / "p1.txt").write_text("0 0.5 0.5 0.25 0.25\n0 0.1 0.1 0 0\n")
    lines: list[str] = []
    cfg = TrainConfig(
        data=[folder, folder], synthetic=0, synthetic_val=1, steps=1, batch=2, width=4, threads=1
    )
    train(cfg, tmp_path / "m.onnx", log=lines.append)
    notes = [line for line in lines if "empty label box" in line]
    assert len(notes) == 1 and "p1.txt:2" in notes[0]


def test_training_can_start_from_saved_weights(tmp_path: Path) -> None:
    """--init: zero steps from saved weights leave them as they were (the start is the file,
    not a fresh network); weights of another shape are an error naming the shape."""
    first = tmp_path / "a.onnx"
    base = TrainConfig(synthetic=2, synthetic_val=1, steps=2, batch=2, width=4, threads=1)
    train(base, first, log=lambda _: None)
    again = tmp_path / "b.onnx"
    meta = train(replace(base, init=first.with_suffix(".pt"), lr=1e-12), again, log=lambda _: None)
    a = torch.load(first.with_suffix(".pt"), weights_only=True)
    b = torch.load(again.with_suffix(".pt"), weights_only=True)
    conv = "stem.0.weight"
    assert torch.allclose(a[conv], b[conv], atol=1e-6)
    fresh = tmp_path / "c.onnx"
    train(replace(base, lr=1e-12), fresh, log=lambda _: None)
    c = torch.load(fresh.with_suffix(".pt"), weights_only=True)
    assert not torch.allclose(a[conv], c[conv], atol=1e-3), "the same seed from scratch differs"
    assert meta["training"]["init"] == str(first.with_suffix(".pt"))  # type: ignore[index]
    # The lineage travels with the weights: a third round lists the first two, oldest first.
    third = tmp_path / "d.onnx"
    train(replace(base, init=again.with_suffix(".pt"), steps=1), third, log=lambda _: None)
    rounds = json.loads(metadata_path(third).read_text())["lineage"]
    a_pt, b_pt = str(first.with_suffix(".pt")), str(again.with_suffix(".pt"))
    assert [r["weights"] for r in rounds] == [a_pt, b_pt]
    assert rounds[0]["training"]["init"] is None and rounds[1]["training"]["lr"] == 1e-12
    assert "validation" in rounds[0] and "lineage" not in rounds[1]
    metadata_path(first).unlink()
    orphan = train(replace(base, init=first.with_suffix(".pt")), third, log=lambda _: None)
    assert orphan["lineage"] == [{"weights": a_pt, "metadata": "none readable"}]
    with pytest.raises(DatasetError, match="--width 4 --blocks 1"):
        train(replace(base, init=first.with_suffix(".pt"), width=8), again, log=lambda _: None)
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not weights")
    with pytest.raises(DatasetError, match="not readable"):
        train(replace(base, init=junk), again, log=lambda _: None)
