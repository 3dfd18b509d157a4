"""Readying a trained detector for the robot: `detector quantize` (int8) keeps the float model's
outputs and never calibrates on held-out images; `detector tune` picks the input size and
threshold with the best held-out F1; both refuse what they cannot do."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from jetson.errors import DatasetError, ModelError
from jetson.perception.cnn.runtime import CnnDetector, input_size, metadata_path, to_input
from jetson.perception.dataset import RingDataset, fingerprint, holdout_names, write_sample
from jetson.perception.evaluate import Counts
from jetson.perception.synthetic import random_frame

torch = pytest.importorskip("torch")
ort = pytest.importorskip("onnxruntime")
onnx = pytest.importorskip("onnx")

from jetson.perception.cnn.model import RingNet  # noqa: E402
from jetson.perception.cnn.quantize import calibration_images, quantize  # noqa: E402
from jetson.perception.cnn.tune import calibration_note, format_table, tune, write_choice  # noqa: E402


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Eight synthetic frames as a dataset folder."""
    root = tmp_path_factory.mktemp("calib")
    rng = np.random.default_rng(5)
    for k in range(8):
        f = random_frame(rng, index=k)
        write_sample(root, f"s{k:02d}", f.frame.color, f.boxes)
    return root


@pytest.fixture(scope="module")
def float_model(
    tmp_path_factory: pytest.TempPathFactory, untrained_ringnet: Callable[..., tuple[RingNet, Path]]
) -> Path:
    path = tmp_path_factory.mktemp("float") / "m.onnx"
    meta = {"input_long_side": 160, "score_threshold": 0.3, "validation": {"x": {"f1": 0.5}}}
    return untrained_ringnet(path, seed=1, width=8, **meta)[1]


def _outputs(model: Path, bgr: np.ndarray) -> list[np.ndarray]:
    session = ort.InferenceSession(str(model), providers=["CPUExecutionProvider"])
    h, w = bgr.shape[:2]
    return session.run(None, {"rgb": to_input(bgr, input_size(w, h, 160))})


def test_int8_model_keeps_the_float_models_outputs(
    float_model: Path, frames: Path, tmp_path: Path
) -> None:
    out = tmp_path / "int8.onnx"
    report = quantize(float_model, [frames], out, frames=6)
    assert report.calibration_images == 6 and report.int8_ms > 0 and report.float_ms > 0
    ops = {n.op_type for n in onnx.load(str(out)).graph.node}
    assert {"QuantizeLinear", "DequantizeLinear"} <= ops, "the convolutions are not quantized"
    meta = json.loads(metadata_path(out).read_text())
    q = meta["quantization"]
    assert q["calibration"] == [{"folder": str(frames), "images": 6}]
    assert q["float_model"] == "m.onnx" and len(q["float_sha256"]) == 64
    assert meta["score_threshold"] == 0.3 and meta["input_long_side"] == 160
    bgr = random_frame(np.random.default_rng(99)).frame.color  # not a calibration image
    (fp, fb), (qp, qb) = _outputs(float_model, bgr), _outputs(out, bgr)
    assert fp.shape == qp.shape and fb.shape == qb.shape
    # Off its 3x3 maxima the heat output is 0, and an untrained network's heat is nearly flat,
    # so which cell wins a tie may differ: compare the heat where both have a peak.
    both = (fp > 0) & (qp > 0)
    assert both.sum() > 10
    assert np.median(np.abs(fp[both] - qp[both]) / fp[both]) < 0.05
    assert np.median(np.abs(fb - qb)) < 0.05
    assert np.abs(fb - qb).max() > 0, "the int8 model computes exactly the float model"
    # The runtime loads it as any other model.
    CnnDetector(out, score_threshold=0.0).detect(bgr)


def _int8_convolutions(model: Path) -> list[str]:
    """The convolutions whose weights come out of a DequantizeLinear: the quantized ones."""
    graph = onnx.load(str(model)).graph
    dequantized = {o for n in graph.node if n.op_type == "DequantizeLinear" for o in n.output}
    return [n.name for n in graph.node if n.op_type == "Conv" and n.input[1] in dequantized]


def test_first_and_last_convolutions_stay_float_unless_asked(
    float_model: Path, frames: Path, tmp_path: Path
) -> None:
    convs = [n.name for n in onnx.load(str(float_model)).graph.node if n.op_type == "Conv"]
    kept = quantize(float_model, [frames], tmp_path / "a.onnx", frames=2)
    assert sorted(_int8_convolutions(kept.out)) == sorted(convs[1:-1])
    q = json.loads(metadata_path(kept.out).read_text())["quantization"]
    assert q["float_nodes"] == [convs[0], convs[-1]]
    every = quantize(float_model, [frames], tmp_path / "b.onnx", frames=2, all_int8=True)
    assert sorted(_int8_convolutions(every.out)) == sorted(convs)
    assert json.loads(metadata_path(every.out).read_text())["quantization"]["float_nodes"] == []


def test_calibration_never_uses_held_out_images(frames: Path) -> None:
    names = sorted(p.stem for p in (frames / "images").iterdir())
    held = holdout_names(names, 0.5, 3)
    meta = {"holdout": {"fraction": 0.5, "seed": 3, "fingerprints": [fingerprint(names)]}}
    picked = [name for _, name, _ in calibration_images([frames], 8, meta)]
    assert picked and not set(picked) & held
    assert len(picked) == len(names) - len(held)  # all the others, each once
    two = [f for f, _, _ in calibration_images([frames, frames], 5, {})]
    assert len(two) == 5


def test_quantize_refuses_what_it_cannot_do(
    float_model: Path, frames: Path, tmp_path: Path
) -> None:
    with pytest.raises(DatasetError, match="at least one --calib"):
        quantize(float_model, [], tmp_path / "a.onnx")
    with pytest.raises(ModelError, match="does not exist"):
        quantize(tmp_path / "none.onnx", [frames], tmp_path / "a.onnx")
    with pytest.raises(ModelError, match="--out must differ"):
        quantize(float_model, [frames], float_model)
    empty = tmp_path / "empty"
    (empty / "images").mkdir(parents=True)
    with pytest.raises(DatasetError):
        quantize(float_model, [empty], tmp_path / "a.onnx")
    once = tmp_path / "once.onnx"
    quantize(float_model, [frames], once, frames=2)
    with pytest.raises(ModelError, match="already quantized"):
        quantize(once, [frames], tmp_path / "twice.onnx")


def test_tune_warns_when_it_moves_an_int8_model_off_its_calibration_size(
    float_model: Path, frames: Path, tmp_path: Path
) -> None:
    int8 = tmp_path / "int8.onnx"
    quantize(float_model, [frames], int8, frames=2)
    assert json.loads(metadata_path(int8).read_text())["quantization"]["input_long_side"] == 160
    assert calibration_note(int8, 160) is None
    note = calibration_note(int8, 96)
    assert note is not None and "calibrated at input 160" in note and float_model.name in note
    assert calibration_note(float_model, 96) is None  # a float model has no calibration


def test_tune_picks_the_best_mean_f1_ties_to_the_smaller_input(
    float_model: Path, frames: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The rule alone, on scores made up per (size, threshold): the best mean over the folders
    wins, and of two equal sizes the smaller (faster) one."""
    import jetson.perception.cnn.tune as tune_module

    other = frames.parent / "other"
    other.mkdir(exist_ok=True)
    for sub in ("images", "labels"):
        (other / sub).symlink_to(frames / sub)
    hits = {(96, 0.5): (8, 8), (128, 0.5): (9, 6), (160, 0.5): (9, 6), (128, 0.3): (5, 9)}

    def made_up(
        detector: CnnDetector, dataset: RingDataset, thresholds: tuple[float, ...]
    ) -> dict[float, Counts]:
        out = {t: Counts() for t in thresholds}
        for t in thresholds:
            a, b = hits.get((detector.info.input_long_side, t), (1, 1))
            out[t].add(10, 10, a if dataset.root == frames else b)
        return out

    monkeypatch.setattr(tune_module, "score_size", made_up)
    tuning = tune(float_model, [frames, other], (160, 128, 96), (0.3, 0.5), progress=False)
    # mean F1 (0.8 + 0.8) / 2 at 96 against (0.9 + 0.6) / 2 at 128 and 160
    assert (tuning.input_long_side, tuning.score_threshold) == (96, 0.5)
    assert tuning.mean_f1 == pytest.approx(0.8)
    hits[(96, 0.5)] = (7, 7)
    tuning = tune(float_model, [frames, other], (160, 128, 96), (0.3, 0.5), progress=False)
    assert (tuning.input_long_side, tuning.score_threshold) == (128, 0.5)  # 160 ties, slower


def test_tune_scores_real_runs_and_records_the_choice(
    float_model: Path, frames: Path, tmp_path: Path
) -> None:
    model = tmp_path / "t.onnx"
    model.write_bytes(float_model.read_bytes())
    metadata_path(model).write_bytes(metadata_path(float_model).read_bytes())
    tuning = tune(model, [frames], sizes=(96, 160), thresholds=(0.01, 0.99), progress=False)
    # An untrained network's heat never reaches 0.99: nothing found there, recall 0.
    assert tuning.table[96][0.99][str(frames)][1] == 0.0
    assert set(tuning.table) == {96, 160} and set(tuning.table[96]) == {0.01, 0.99}
    assert "*" in format_table(tuning) and set(tuning.network_ms) == {96, 160}
    assert all(v > 0 for v in tuning.network_ms.values())
    write_choice(model, tuning)
    meta = json.loads(metadata_path(model).read_text())
    assert meta["input_long_side"] == tuning.input_long_side
    assert meta["score_threshold"] == tuning.score_threshold
    assert meta["tuning"]["from"] == {"input_long_side": 160, "score_threshold": 0.3}
    assert set(meta["tuning"]["f1"]) == {"96", "160"}
    assert CnnDetector(model).info.input_long_side == tuning.input_long_side
    assert "tuning_history" not in meta
    # Tuned again (as an int8 model's threshold is): the earlier table is kept, not lost.
    write_choice(model, replace(tuning, score_threshold=0.99))
    meta = json.loads(metadata_path(model).read_text())
    assert meta["tuning_history"][0]["from"] == {"input_long_side": 160, "score_threshold": 0.3}
    assert meta["tuning"]["from"]["input_long_side"] == tuning.input_long_side
    assert meta["score_threshold"] == 0.99
    with pytest.raises(DatasetError, match="at least one --val"):
        tune(model, [], progress=False)
    with pytest.raises(DatasetError, match="at least 16"):
        tune(model, [frames], sizes=(8,), progress=False)
    with pytest.raises(DatasetError, match=r"lie in \(0, 1\)"):
        tune(model, [frames], thresholds=(1.5,), progress=False)
