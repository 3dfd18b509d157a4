"""Which onnxruntime execution providers run a model: one rule for the policy and the detector.

Without a setting, the best one this onnxruntime has: TensorRT, then CUDA, then the CPU (NVIDIA's
onnxruntime-gpu build for a Jetson has the first two; the PyPI wheel has only the CPU). A setting
(`[policy] providers`, `[camera] providers`) names them in order of preference, by short name
(tensorrt, cuda, cpu) or by onnxruntime's own (CUDAExecutionProvider); one that this onnxruntime
lacks is an error that names what it has. The CPU always comes last, for what the others cannot
run. `open_session` opens a model with them and says which one onnxruntime took: it falls back
by itself when a provider fails to start (e.g. TensorRT's libraries are missing).

No onnxruntime at module level: jetson.settings checks the names with `provider_names`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

TENSORRT = "TensorrtExecutionProvider"
CUDA = "CUDAExecutionProvider"
CPU = "CPUExecutionProvider"
PREFERENCE = (TENSORRT, CUDA, CPU)
SHORT_NAMES = {"tensorrt": TENSORRT, "cuda": CUDA, "cpu": CPU}


def provider_names(wanted: Sequence[str]) -> tuple[str, ...]:
    """onnxruntime's names for a providers setting (short names or onnxruntime's); ValueError,
    naming the entry, for anything else, an empty list or a repeat."""
    if isinstance(wanted, str) or not isinstance(wanted, Sequence):
        raise ValueError(f"must be a list of names, e.g. ['cuda', 'cpu'], not {wanted!r}")
    if not wanted:
        raise ValueError("is empty: leave it out to use the best one installed")
    names = []
    for entry in wanted:
        if not isinstance(entry, str):
            raise ValueError(f"{entry!r} is not a name")
        name = SHORT_NAMES.get(entry.strip().lower(), entry.strip())
        if not name.endswith("ExecutionProvider"):
            raise ValueError(
                f"unknown execution provider {entry!r} (tensorrt, cuda, cpu, or "
                "onnxruntime's name such as CUDAExecutionProvider)"
            )
        if name in names:
            raise ValueError(f"{entry!r} is named twice")
        names.append(name)
    return tuple(names)


def choose_providers(available: Sequence[str], wanted: Sequence[str] | None = None) -> list[str]:
    """The providers to open a session with, best first: `wanted` (a setting) if given, each of
    which must be available, else the best of `available` (onnxruntime.get_available_providers())
    in the order TensorRT, CUDA, CPU. The CPU ends the list either way."""
    if wanted is None:
        chosen = [p for p in PREFERENCE if p in available]
    else:
        chosen = list(provider_names(wanted))
        missing = [p for p in chosen if p not in available and p != CPU]
        if missing:
            raise ValueError(
                f"execution provider {missing[0]} is not in this onnxruntime (it has "
                f"{', '.join(available) or 'none'}): install NVIDIA's onnxruntime-gpu build "
                "(jetson/README.md) or change the providers setting"
            )
    if CPU not in chosen:
        chosen.append(CPU)
    return chosen


def tensorrt_cache_dir() -> Path | None:
    """Where TensorRT keeps the engines it builds, so that only the first start builds them
    (minutes on a Jetson): systemd's CacheDirectory= ($CACHE_DIRECTORY), else the user's cache
    folder; None when it cannot be made (then every start builds them)."""
    base = os.environ.get("CACHE_DIRECTORY") or os.environ.get("XDG_CACHE_HOME")
    try:
        root = Path(base) if base else Path.home() / ".cache"
        path = root / "pete-jetson" / "tensorrt"
        path.mkdir(parents=True, exist_ok=True)
    except (OSError, RuntimeError):  # RuntimeError: no home folder to be found
        return None
    return path if os.access(path, os.W_OK) else None


def open_session(
    path: Path, threads: int = 1, wanted: Sequence[str] | None = None
) -> tuple[Any, str]:
    """(onnxruntime session, the provider it runs on) for the model at `path`, on `threads`
    intra-op threads. ValueError for providers that cannot be had (see choose_providers);
    onnxruntime's own exceptions for a model it cannot load; ImportError without onnxruntime."""
    import onnxruntime as ort

    providers: list[Any] = choose_providers(ort.get_available_providers(), wanted)
    if TENSORRT in providers and (cache := tensorrt_cache_dir()) is not None:
        options = {"trt_engine_cache_enable": True, "trt_engine_cache_path": str(cache)}
        providers[providers.index(TENSORRT)] = (TENSORRT, options)
    session_options = ort.SessionOptions()
    session_options.intra_op_num_threads = threads
    session_options.inter_op_num_threads = 1
    session = ort.InferenceSession(str(path), session_options, providers=providers)
    used = session.get_providers()
    return session, used[0] if used else CPU
