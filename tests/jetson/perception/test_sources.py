"""Camera sources: recordings, the socket frame stream, images, RealSense errors."""

from __future__ import annotations

import socket
import struct
import sys
import threading
import types
from pathlib import Path

import cv2
import numpy as np
import pytest

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError
from jetson.perception.frame import Frame
from jetson.perception.sources import open_source
from jetson.perception.sources.images import ImageFolderSource
from jetson.perception.sources.realsense import RealSenseSource
from jetson.perception.sources.recording import Recorder, RecordingSource
from jetson.perception.sources.stream import (
    HEADER,
    FrameStreamServer,
    StreamSource,
    encode_header,
    parse_address,
)

INTR = Intrinsics(64, 48, 60.0, 61.0, 31.5, 23.5, (0.01, -0.02, 0.0, 0.0, 0.003))


def make_frame(index: int, depth: bool = True) -> Frame:
    rng = np.random.default_rng(index)
    color = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    d = rng.uniform(0.2, 5.0, (48, 64)).astype(np.float32) if depth else None
    if d is not None:
        d[0, :5] = 0.0  # no reading
    return Frame(color, d, INTR, 10.0 + index / 30.0, index)


def assert_same(a: Frame, b: Frame) -> None:
    assert np.array_equal(a.color, b.color)
    assert a.intrinsics == b.intrinsics
    assert a.timestamp_s == pytest.approx(b.timestamp_s, abs=1e-9)
    assert a.index == b.index
    if a.depth_m is None:
        assert b.depth_m is None
    else:
        assert b.depth_m is not None
        # Depth travels as whole millimetres, as the D435 reports it.
        assert np.abs(a.depth_m - b.depth_m).max() <= 0.0005 + 1e-6
        assert np.array_equal(a.depth_m == 0, b.depth_m == 0)


def test_frame_checks_its_arrays() -> None:
    with pytest.raises(SourceError, match="colour is 64x48 but the intrinsics are for 32x24"):
        Frame(np.zeros((48, 64, 3), np.uint8), None, INTR.scaled(32, 24), 0.0)
    with pytest.raises(SourceError, match="depth"):
        Frame(np.zeros((48, 64, 3), np.uint8), np.zeros((10, 10), np.float32), INTR, 0.0)
    with pytest.raises(SourceError, match="uint8"):
        Frame(np.zeros((48, 64, 3), np.float32), None, INTR, 0.0)  # type: ignore[arg-type]


def test_recording_round_trip(tmp_path: Path) -> None:
    frames = [make_frame(i, depth=(i != 2)) for i in range(4)]
    with Recorder(tmp_path / "rec", source="test") as rec:
        for f in frames:
            rec.write(f)
    src = open_source(str(tmp_path / "rec"))
    assert isinstance(src, RecordingSource) and len(src) == 4
    with src:
        back = list(src)
    assert len(back) == 4
    for a, b in zip(frames, back, strict=True):
        assert_same(a, b)


def test_recording_cut_short_plays_up_to_its_last_whole_frame(tmp_path: Path) -> None:
    with Recorder(tmp_path, source="test") as rec:
        rec.write(make_frame(0))
        rec.write(make_frame(1))
    index = tmp_path / "frames.jsonl"
    index.write_text(index.read_text() + '{"index": 2, "timest')  # a crash mid-line
    assert len(RecordingSource(tmp_path)) == 2


def test_recorder_refuses_to_overwrite_and_bad_recordings_are_named(tmp_path: Path) -> None:
    with Recorder(tmp_path, source="test") as rec:
        rec.write(make_frame(0))
    with pytest.raises(SourceError, match="already holds a recording"):
        Recorder(tmp_path)
    (tmp_path / "recording.json").write_text('{"format": "something-else"}')
    with pytest.raises(SourceError, match="is not a pete-recording"):
        RecordingSource(tmp_path)
    with pytest.raises(SourceError, match="not a recording"):
        RecordingSource(tmp_path / "color")


def _serve(server: FrameStreamServer, frames: list[Frame]) -> None:
    assert server.wait_for_client(5.0)
    for f in frames:
        assert server.send(f)
    server.close()


@pytest.mark.parametrize("kind", ["unix", "tcp"])
def test_frame_stream_round_trip(tmp_path: Path, kind: str) -> None:
    address = f"unix:{tmp_path / 'cam.sock'}" if kind == "unix" else "tcp:127.0.0.1:0"
    server = FrameStreamServer(address)
    frames = [make_frame(i, depth=(i % 2 == 0)) for i in range(5)]
    t = threading.Thread(target=_serve, args=(server, frames))
    t.start()
    try:
        with open_source(server.address) as src:
            back = list(src)
    finally:
        t.join(5.0)
    assert len(back) == 5
    for a, b in zip(frames, back, strict=True):
        assert_same(a, b)
    if kind == "unix":
        assert not (tmp_path / "cam.sock").exists()  # the server cleans up after itself


def test_a_client_that_comes_back_is_taken_without_waiting(tmp_path: Path) -> None:
    """A camera thread that gave up on a quiet stream connects again; the server takes it at its
    next frame (accept_pending) and the frames flow to the new connection."""
    server = FrameStreamServer(f"unix:{tmp_path / 'cam.sock'}")
    try:
        assert not server.accept_pending()  # nobody waiting: no wait either
        first = StreamSource(server.address)
        assert server.accept_pending() and server.connected
        first.close()  # gave up
        again = StreamSource(server.address)
        assert server.accept_pending()
        frame = make_frame(7, depth=True)
        assert server.send(frame)
        assert_same(frame, next(iter(again)))
        again.close()
    finally:
        server.close()


def test_a_missing_stream_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match=r"no frame stream at unix:.*is the simulator"):
        StreamSource(f"unix:{tmp_path / 'nobody.sock'}", connect_timeout_s=0.1)
    with pytest.raises(SourceError, match="bad stream address"):
        parse_address("udp:1.2.3.4:5")


def _raw_server(tmp_path: Path, payload: bytes, name: str = "raw") -> tuple[str, threading.Thread]:
    """A server that writes `payload` (not necessarily a valid frame) and hangs up."""
    path = str(tmp_path / f"{name}.sock")
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path)
    listener.listen(1)

    def run() -> None:
        conn, _ = listener.accept()
        conn.sendall(payload)
        conn.close()
        listener.close()

    t = threading.Thread(target=run)
    t.start()
    return f"unix:{path}", t


def test_a_stream_cut_mid_frame_is_an_error(tmp_path: Path) -> None:
    frame = make_frame(0)
    data = encode_header(frame) + frame.color.tobytes()[:100]
    address, t = _raw_server(tmp_path, data)
    with StreamSource(address) as src, pytest.raises(SourceError, match="middle of a frame"):
        src.read()
    t.join(5.0)


def test_a_stream_with_bad_magic_or_size_is_an_error(tmp_path: Path) -> None:
    bad = b"JUNK" + bytes(HEADER.size - 4)
    address, t = _raw_server(tmp_path, bad)
    with StreamSource(address) as src, pytest.raises(SourceError, match="bad magic"):
        src.read()
    t.join(5.0)
    header = bytearray(encode_header(make_frame(0)))
    struct.pack_into("<I", header, HEADER.size - 4, 7)  # payload size that cannot be right
    address, t = _raw_server(tmp_path, bytes(header), "raw2")
    with StreamSource(address) as src, pytest.raises(SourceError, match="payload 7 bytes"):
        src.read()
    t.join(5.0)


def test_a_second_server_on_a_live_socket_is_refused(tmp_path: Path) -> None:
    address = f"unix:{tmp_path / 'cam.sock'}"
    with FrameStreamServer(address), pytest.raises(SourceError, match="in use"):
        FrameStreamServer(address)
    # A stale socket file (its server gone) is replaced.
    stale = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stale.bind(str(tmp_path / "stale.sock"))
    stale.close()
    FrameStreamServer(f"unix:{tmp_path / 'stale.sock'}").close()


def test_image_folder_source_uses_depth_beside_a_dataset(tmp_path: Path) -> None:
    (tmp_path / "images").mkdir()
    (tmp_path / "depth").mkdir()
    for i in range(2):
        cv2.imwrite(str(tmp_path / "images" / f"{i}.png"), make_frame(i).color)
    cv2.imwrite(str(tmp_path / "depth" / "0.png"), np.full((48, 64), 1500, np.uint16))
    src = open_source(str(tmp_path), INTR)
    assert isinstance(src, ImageFolderSource)
    first, second = list(src)
    assert first.depth_m is not None and float(first.depth_m[0, 0]) == pytest.approx(1.5)
    assert second.depth_m is None
    assert first.intrinsics == INTR


def test_missing_sources_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match="does not exist"):
        open_source(str(tmp_path / "nothing"))
    with pytest.raises(SourceError, match="holds no images"):
        open_source(str(tmp_path))
    (tmp_path / "notes.txt").write_text("hi")
    with pytest.raises(SourceError, match=r"not a folder, .bag or video"):
        open_source(str(tmp_path / "notes.txt"))


def test_realsense_without_pyrealsense2_says_how_to_install(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)  # import raises ImportError
    with pytest.raises(SourceError, match=r"pacman-pete\[realsense\]"):
        open_source("realsense")
    with pytest.raises(SourceError, match=r"pacman-pete\[realsense\]"):
        RealSenseSource(bag="x.bag")


class _FakeContext:
    def __init__(self, n: int) -> None:
        self.n = n

    def query_devices(self) -> list[object]:
        return [object()] * self.n


def _fake_rs(n_devices: int) -> types.SimpleNamespace:
    """Just enough of pyrealsense2 to reach the device check."""
    return types.SimpleNamespace(context=lambda: _FakeContext(n_devices))


def test_realsense_with_no_camera_connected_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match="no RealSense camera connected"):
        RealSenseSource(rs=_fake_rs(0))  # type: ignore[arg-type]
    with pytest.raises(SourceError, match=r"recording .* does not exist"):
        RealSenseSource(bag=tmp_path / "missing.bag", rs=_fake_rs(0))  # type: ignore[arg-type]


class _FakeRs:
    """A stand-in for pyrealsense2 that plays two framesets from a "bag": enough to run
    RealSenseSource's start, alignment, conversion and end-of-file logic without a camera."""

    class stream:  # noqa: N801 - pyrealsense2's names
        color, depth = "color", "depth"

    class format:  # noqa: N801
        bgr8, rgb8, rgba8, bgra8, z16 = "bgr8", "rgb8", "rgba8", "bgra8", "z16"

    def __init__(self, n_frames: int) -> None:
        rgb = np.zeros((48, 64, 3), np.uint8)
        rgb[..., 0] = 200  # red in RGB order
        self.frames = [(rgb, np.full((48, 64), 1500, np.uint16), 1000.0 * (i + 1), i) for i in
                       range(n_frames)]  # fmt: skip
        self.config_calls: list[tuple[object, ...]] = []
        fake = self

        class Profile:
            def format(self) -> str:
                return "rgb8"

        class Data:
            def __init__(self, arr: np.ndarray, ts: float = 0.0, n: int = 0) -> None:
                self.arr, self.ts, self.n = arr, ts, n

            def get_data(self) -> np.ndarray:
                return self.arr

            def get_profile(self) -> Profile:
                return Profile()

            def get_timestamp(self) -> float:
                return self.ts

            def get_frame_number(self) -> int:
                return self.n

        class Frames:
            def __init__(self, item: tuple[np.ndarray, np.ndarray, float, int]) -> None:
                self.item = item

            def get_color_frame(self) -> Data:
                c, _, ts, n = self.item
                return Data(c, ts, n)

            def get_depth_frame(self) -> Data:
                return Data(self.item[1])

        class Pipeline:
            def __init__(self) -> None:
                self.left = list(fake.frames)

            def start(self, config: object) -> object:
                intr = types.SimpleNamespace(width=64, height=48, fx=60.0, fy=61.0, ppx=31.5,
                                             ppy=23.5, coeffs=[0.0] * 5)  # fmt: skip
                sensor = types.SimpleNamespace(get_depth_scale=lambda: 0.001)
                device = types.SimpleNamespace(
                    as_playback=lambda: types.SimpleNamespace(set_real_time=lambda _: None),
                    first_depth_sensor=lambda: sensor,
                )
                vsp = types.SimpleNamespace(get_intrinsics=lambda: intr)
                stream = types.SimpleNamespace(as_video_stream_profile=lambda: vsp)
                return types.SimpleNamespace(get_device=lambda: device, get_stream=lambda _: stream)

            def try_wait_for_frames(self, timeout_ms: int) -> tuple[bool, object]:
                if not self.left:
                    return False, None
                return True, Frames(self.left.pop(0))

            def stop(self) -> None:
                pass

        class Config:
            def enable_device_from_file(self, path: str, repeat_playback: bool) -> None:
                fake.config_calls.append(("file", path, repeat_playback))

        self.pipeline = Pipeline
        self.config = Config
        self.align = lambda _: types.SimpleNamespace(process=lambda frames: frames)


def test_realsense_bag_playback_converts_frames_and_ends(tmp_path: Path) -> None:
    bag = tmp_path / "x.bag"
    bag.write_bytes(b"")
    rs = _FakeRs(2)
    with RealSenseSource(bag=bag, rs=rs) as src:  # type: ignore[arg-type]
        frames = list(src)
    assert rs.config_calls == [("file", str(bag), False)]
    assert len(frames) == 2
    f = frames[1]
    assert f.color[0, 0].tolist() == [0, 0, 200]  # RGB from the bag, BGR in the frame
    assert f.depth_m is not None and float(f.depth_m[0, 0]) == pytest.approx(1.5)
    assert f.timestamp_s == pytest.approx(2.0) and f.index == 1
    assert f.intrinsics == Intrinsics(64, 48, 60.0, 61.0, 31.5, 23.5)


def test_synthetic_frames_come_at_their_rate_with_rings_and_depth() -> None:
    import time

    from jetson.perception.camera import CameraConfig
    from jetson.perception.pipeline import Pipeline, make_detector

    src = open_source("synthetic:40")
    t0 = time.monotonic()
    frames = [src.read() for _ in range(20)]
    spent = time.monotonic() - t0
    assert 0.4 <= spent < 1.5, spent  # 20 frames at 40 a second: half a second, never faster
    assert [f.index for f in frames] == list(range(1, 21))
    f = frames[0]
    assert f.color.shape == (480, 640, 3) and f.depth_m is not None and f.depth_m.max() > 0
    camera = CameraConfig()
    found = Pipeline(make_detector("classical", camera), camera).process(f)
    assert len(found.rings_robot_xy) > 0  # the scenes hold rings the detector finds
    for bad in ("synthetic:abc", "synthetic:0", "synthetic:-5"):
        with pytest.raises(SourceError, match="synthetic"):
            open_source(bad)
