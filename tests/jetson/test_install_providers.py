"""onnxruntime's execution providers: the best installed (TensorRT, CUDA, CPU) or as the settings
say, for the policy and the detector alike, and the daemon's log names the one in use. A fake
onnxruntime module plays a GPU build; the last tests use the real (CPU) one."""

from __future__ import annotations

import io
import json
import sys
import types
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest

from jetson.autonomy.policy import OnnxPolicy
from jetson.autonomy.providers import (
    CPU,
    CUDA,
    TENSORRT,
    choose_providers,
    open_session,
    provider_names,
)
from jetson.errors import ModelError, PolicyError, SettingsError
from jetson.models import DEFAULT_DETECTOR, DEFAULT_POLICY
from jetson.perception.cnn.runtime import CnnDetector
from jetson.settings import Settings

GPU_BUILD = ["TensorrtExecutionProvider", "CUDAExecutionProvider", "CPUExecutionProvider"]
POLICY_INPUT = json.loads(DEFAULT_POLICY.with_suffix(".json").read_text())["input"]["name"]


class FakeOrt(types.ModuleType):
    """onnxruntime as a GPU build shows itself: get_available_providers(), SessionOptions and
    InferenceSession, which drops a provider in `broken` and goes on with the rest, as
    onnxruntime's Python binding does when one fails to start."""

    def __init__(self, available: Sequence[str], broken: Sequence[str] = ()) -> None:
        super().__init__("onnxruntime")
        self.available = list(available)
        self.broken = set(broken)
        self.sessions: list[Any] = []
        fake = self

        class SessionOptions:
            intra_op_num_threads = 0
            inter_op_num_threads = 0

        class InferenceSession:
            def __init__(self, path: str, options: Any, providers: Sequence[Any]) -> None:
                self.path, self.options, self.asked = path, options, list(providers)
                names = [p[0] if isinstance(p, tuple) else p for p in providers]
                self.used = [p for p in names if p not in fake.broken]
                fake.sessions.append(self)

            def get_providers(self) -> list[str]:
                return self.used

            def get_inputs(self) -> list[Any]:
                return [types.SimpleNamespace(name=POLICY_INPUT)]

        self.SessionOptions = SessionOptions
        self.InferenceSession = InferenceSession

    def get_available_providers(self) -> list[str]:
        return list(self.available)


@pytest.fixture
def fake_ort(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Any:
    def install(available: Sequence[str] = GPU_BUILD, broken: Sequence[str] = ()) -> FakeOrt:
        module = FakeOrt(available, broken)
        monkeypatch.setitem(sys.modules, "onnxruntime", module)
        return module

    monkeypatch.setenv("CACHE_DIRECTORY", str(tmp_path / "cache"))
    return install


@pytest.mark.parametrize(
    ("available", "chosen"),
    [
        (GPU_BUILD, [TENSORRT, CUDA, CPU]),
        ([CPU, CUDA, TENSORRT], [TENSORRT, CUDA, CPU]),  # our order, not onnxruntime's
        ([CUDA, CPU], [CUDA, CPU]),
        (["AzureExecutionProvider", CPU], [CPU]),
        ([CPU], [CPU]),
        ([], [CPU]),
    ],
)
def test_without_a_setting_the_best_installed_comes_first(
    available: list[str], chosen: list[str]
) -> None:
    assert choose_providers(available) == chosen


def test_a_setting_picks_them_in_its_order_and_the_cpu_ends_the_list() -> None:
    assert choose_providers(GPU_BUILD, ["cuda"]) == [CUDA, CPU]
    assert choose_providers(GPU_BUILD, ["cpu"]) == [CPU]
    assert choose_providers(GPU_BUILD, ["CUDAExecutionProvider", "tensorrt"]) == [
        CUDA,
        TENSORRT,
        CPU,
    ]
    assert choose_providers([CPU], ["cpu"]) == [CPU]


def test_a_provider_that_is_not_installed_is_named_with_what_is() -> None:
    expected = r"TensorrtExecutionProvider is not in this onnxruntime \(it has CPUExecution"
    with pytest.raises(ValueError, match=expected):
        choose_providers([CPU], ["tensorrt", "cpu"])


@pytest.mark.parametrize(
    ("wanted", "message"),
    [
        (["gpu"], "unknown execution provider 'gpu'"),
        ("cuda", "must be a list of names"),
        ([], "is empty"),
        (["cuda", "CUDAExecutionProvider"], "'CUDAExecutionProvider' is named twice"),
        ([3], "3 is not a name"),
    ],
)
def test_bad_provider_names_are_refused(wanted: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        provider_names(wanted)


def test_open_session_asks_for_them_in_order_with_a_tensorrt_engine_cache(
    fake_ort: Any, tmp_path: Path
) -> None:
    ort = fake_ort()
    session, provider = open_session(DEFAULT_POLICY, threads=2)
    assert provider == TENSORRT
    assert [p[0] if isinstance(p, tuple) else p for p in session.asked] == [TENSORRT, CUDA, CPU]
    _, options = session.asked[0]
    assert options == {
        "trt_engine_cache_enable": True,
        "trt_engine_cache_path": str(tmp_path / "cache" / "pete-jetson" / "tensorrt"),
    }
    assert Path(options["trt_engine_cache_path"]).is_dir()
    assert session.options.intra_op_num_threads == 2 and ort.sessions == [session]


def test_the_provider_in_use_is_the_one_onnxruntime_took(fake_ort: Any) -> None:
    """TensorRT's libraries missing: onnxruntime falls back to CUDA, and that is what is said."""
    fake_ort(broken=[TENSORRT])
    _, provider = open_session(DEFAULT_POLICY)
    assert provider == CUDA


def test_the_policy_runs_on_the_best_provider_or_the_one_asked_for(fake_ort: Any) -> None:
    ort = fake_ort()
    assert OnnxPolicy(DEFAULT_POLICY).provider == TENSORRT
    policy = OnnxPolicy(DEFAULT_POLICY, providers=["cpu"])
    assert policy.provider == CPU and ort.sessions[-1].asked == [CPU]
    assert ort.sessions[-1].options.intra_op_num_threads == 1


def test_the_policy_refuses_a_provider_that_is_not_installed(fake_ort: Any) -> None:
    fake_ort(available=[CPU])
    with pytest.raises(PolicyError, match=r"policy\.onnx: execution provider CUDAExecution"):
        OnnxPolicy(DEFAULT_POLICY, providers=["cuda"])


def test_the_detector_runs_on_the_best_provider_or_the_one_asked_for(fake_ort: Any) -> None:
    ort = fake_ort()
    assert CnnDetector(DEFAULT_DETECTOR).provider == TENSORRT
    detector = CnnDetector(DEFAULT_DETECTOR, threads=3, providers=["cuda", "cpu"])
    assert detector.provider == CUDA and ort.sessions[-1].asked == [CUDA, CPU]
    assert ort.sessions[-1].options.intra_op_num_threads == 3


def test_the_detector_refuses_a_provider_that_is_not_installed(fake_ort: Any) -> None:
    fake_ort(available=[CUDA, CPU])
    with pytest.raises(ModelError, match=r"ringnet\.onnx: execution provider Tensorrt"):
        CnnDetector(DEFAULT_DETECTOR, providers=["tensorrt"])


def test_settings_take_providers_for_the_policy_and_the_camera(tmp_path: Path) -> None:
    path = tmp_path / "pete.toml"
    path.write_text('[policy]\nproviders = ["cpu"]\n[camera]\nproviders = ["tensorrt", "cuda"]\n')
    settings = Settings.load(path)
    assert settings.policy.providers == ("cpu",)
    assert settings.camera.providers == ("tensorrt", "cuda")
    assert Settings().policy.providers is None and Settings().camera.providers is None


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            '[policy]\nproviders = ["gpu"]\n',
            r"policy providers: unknown execution provider 'gpu'",
        ),
        ("[camera]\nproviders = []\n", r"camera providers: is empty"),
    ],
)
def test_settings_refuse_bad_providers(tmp_path: Path, body: str, message: str) -> None:
    path = tmp_path / "pete.toml"
    path.write_text(body)
    with pytest.raises(SettingsError, match=message):
        Settings.load(path)


def daemon_log(settings: Settings) -> list[dict[str, Any]]:
    """What build() logs, its camera a thread of this process (a lockstep clock), so that the
    detector is made here with the fake onnxruntime; tests/jetson/test_camera_process.py has
    the camera's own process log its detector's provider."""
    from jetson.clock import ManualClock
    from jetson.service import build

    stream = io.StringIO()
    build(settings, ManualClock(), log_stream=stream, human_stream=io.StringIO())
    return [json.loads(line) for line in stream.getvalue().splitlines()]


def test_the_daemon_logs_the_provider_of_the_policy_and_the_detector(
    fake_ort: Any, tmp_path: Path
) -> None:
    fake_ort(broken=[TENSORRT])
    settings = Settings().with_overrides(
        camera={"source": str(tmp_path), "providers": ("cuda",)}, record={"dir": ""}
    )
    lines = [r for r in daemon_log(settings) if r["event"] == "onnxruntime"]
    assert [r["msg"] for r in lines] == [
        "policy runs on CUDAExecutionProvider",
        "ring detector runs on CUDAExecutionProvider",
    ]
    assert lines[0]["policy"] == CUDA and lines[1]["detector"] == CUDA


def test_the_real_onnxruntime_runs_both_on_what_it_has() -> None:
    """This machine's onnxruntime, as installed: the CPU build runs both on the CPU."""
    ort = pytest.importorskip("onnxruntime")
    best = choose_providers(ort.get_available_providers())[0]
    policy = OnnxPolicy(DEFAULT_POLICY)
    assert policy.provider == best
    assert CnnDetector(DEFAULT_DETECTOR).provider == best
    assert OnnxPolicy(DEFAULT_POLICY, providers=["cpu"]).provider == CPU
