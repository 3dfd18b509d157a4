"""`pete-jetson` perception commands: help, errors, and small end-to-end runs."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from jetson.cli import build_parser, main
from jetson.perception.camera import CameraConfig
from jetson.perception.sources.recording import Recorder
from jetson.perception.synthetic import Ring, Scene, render

COMMANDS = [
    ["ports"],
    ["detect"],
    ["detector"],
    ["detector", "train"],
    ["detector", "quantize"],
    ["detector", "tune"],
    ["detector", "eval"],
    ["detector", "synth"],
    ["calibrate"],
    ["record"],
]


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_every_command_has_help(command: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main([*command, "--help"])
    assert exc.value.code == 0
    assert "usage: pete-jetson" in capsys.readouterr().out


def test_top_level_help_lists_the_perception_commands() -> None:
    text = build_parser().format_help()
    for name in ("ports", "detect", "detector", "calibrate", "record"):
        assert f"pete-jetson {name}" in text


def test_missing_arguments_are_usage_errors(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["detector", "eval"])
    assert exc.value.code == 2
    assert "--images" in capsys.readouterr().err


def test_errors_are_one_line_not_tracebacks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "d" / "images").mkdir(parents=True)
    cv2.imwrite(str(tmp_path / "d" / "images" / "a.png"), np.zeros((48, 64, 3), np.uint8))
    cases = [
        (["detect", "--source", str(tmp_path / "none"), "--out", str(tmp_path / "o")],
         "does not exist"),
        (["detect", "--source", f"unix:{tmp_path / 'x.sock'}", "--out", str(tmp_path / "o"),
          "--detector", "classical"], "no frame stream"),
        (["detector", "eval", "--images", str(tmp_path)], "no images/ folder"),
        (["detector", "eval", "--images", str(tmp_path / "d"), "--model", str(tmp_path / "m.onnx")],
         "m.onnx does not exist"),
        (["detector", "train", "--out", str(tmp_path / "m.onnx")], "nothing to train on"),
        (["detector", "train", "--synthetic", "1", "--strong-cast", "1.5", "--out",
          str(tmp_path / "m.onnx")], "--strong-cast is a share of samples"),
        (["detector", "train", "--synthetic", "1", "--patch", "200x160", "--out",
          str(tmp_path / "m.onnx")], "multiples of 16"),
        (["detector", "train", "--synthetic", "1", "--patch", "wide", "--out",
          str(tmp_path / "m.onnx")], "WIDTHxHEIGHT"),
        (["detector", "quantize", "--model", str(tmp_path / "m.onnx"), "--calib",
          str(tmp_path / "d"), "--out", str(tmp_path / "q.onnx")], "m.onnx does not exist"),
        (["detector", "tune", "--model", str(tmp_path / "m.onnx"), "--val", str(tmp_path / "d"),
          "--sizes", "480,big"], "comma-separated numbers"),
        (["detector", "tune", "--model", str(tmp_path / "m.onnx"), "--val", str(tmp_path / "d")],
         "m.onnx does not exist"),
        (["calibrate", "--images", str(tmp_path), "--board", "9by6", "--square-mm", "25"],
         "COLSxROWS"),
        (["detect", "--source", str(tmp_path), "--out", str(tmp_path / "o"),
          "--camera", str(tmp_path / "cam.json")], "camera config"),
    ]  # fmt: skip
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("pete-jetson: error: ") and message in err, (argv, err)
        assert "Traceback" not in err


def _recording(path: Path) -> list[tuple[float, float]]:
    cam = CameraConfig()
    intr = cam.intrinsics.scaled(320, 240)
    truths = [(0.0, 0.9), (0.25, 1.3)]
    r = render(Scene(rings=[Ring(x, y) for x, y in truths]), intr, cam.mount, None)
    with Recorder(path) as rec:
        rec.write(r.frame)
        rec.write(r.frame)
    return truths


def test_detect_writes_annotated_images_plots_and_positions(tmp_path: Path) -> None:
    truths = _recording(tmp_path / "rec")
    out = tmp_path / "out"
    argv = ["detect", "--source", str(tmp_path / "rec"), "--out", str(out),
            "--detector", "classical"]  # fmt: skip
    assert main(argv) == 0
    assert sorted(p.name for p in (out / "annotated").iterdir()) == ["000000.png", "000001.png"]
    assert len(list((out / "topdown").iterdir())) == 2
    lines = [json.loads(line) for line in (out / "rings.jsonl").read_text().splitlines()]
    assert len(lines) == 2
    xy = lines[0]["rings_robot_xy"]
    assert len(xy) == 2
    for (x, y), (tx, ty) in zip(xy, sorted(truths, key=lambda p: p[1]), strict=True):
        assert abs(x - tx) < 0.04 and abs(y - ty) < 0.04


def test_detect_can_write_video(tmp_path: Path) -> None:
    _recording(tmp_path / "rec")
    out = tmp_path / "out"
    argv = ["detect", "--source", str(tmp_path / "rec"), "--out", str(out),
            "--detector", "classical", "--video", "--prefilter"]  # fmt: skip
    assert main(argv) == 0
    assert (out / "annotated.mp4").stat().st_size > 0
    assert (out / "topdown.mp4").stat().st_size > 0


def test_synth_then_eval(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "synth"
    argv = ["detector", "synth", "--frames", "3", "--out", str(data), "--seed", "7",
            "--width", "320", "--height", "240"]  # fmt: skip
    assert main(argv) == 0
    assert len(list((data / "images").iterdir())) == 3
    assert len(list((data / "truth").iterdir())) == 3
    capsys.readouterr()
    assert main(["detector", "eval", "--images", str(data), "--detector", "classical"]) == 0
    out = capsys.readouterr().out
    for word in ("precision", "recall", "F1", "of the ring visible"):
        assert word in out


def test_record_a_frame_stream_then_play_it_back(tmp_path: Path) -> None:
    import threading

    from jetson.perception.sources.recording import RecordingSource
    from jetson.perception.sources.stream import FrameStreamServer

    cam = CameraConfig()
    intr = cam.intrinsics.scaled(160, 120)
    frames = [render(Scene(rings=[Ring(0.0, 1.0 + 0.1 * k)]), intr, cam.mount, None).frame
              for k in range(3)]  # fmt: skip
    server = FrameStreamServer(f"unix:{tmp_path / 'cam.sock'}")

    def serve() -> None:
        assert server.wait_for_client(5.0)
        for f in frames:
            server.send(f)
        server.close()

    t = threading.Thread(target=serve)
    t.start()
    try:
        assert main(["record", "--source", server.address, "--out", str(tmp_path / "rec")]) == 0
    finally:
        t.join(5.0)
    back = list(RecordingSource(tmp_path / "rec"))
    assert len(back) == 3
    assert all(np.array_equal(a.color, b.color) for a, b in zip(frames, back, strict=True))
