"""What perception may import: never the simulator, and torch only where training needs it."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

PERCEPTION = Path(__file__).resolve().parents[3] / "jetson" / "perception"
TORCH_ALLOWED = {"cnn/model.py", "cnn/train.py"}


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def test_perception_never_imports_the_simulator_and_keeps_torch_to_training() -> None:
    files = sorted(PERCEPTION.rglob("*.py"))
    assert len(files) > 10
    for path in files:
        rel = path.relative_to(PERCEPTION).as_posix()
        mods = imported_modules(path)
        assert not any(m == "sim" or m.startswith("sim.") for m in mods), rel
        if rel not in TORCH_ALLOWED:
            assert not any(m == "torch" or m.startswith("torch.") for m in mods), rel


def test_the_inference_path_loads_without_torch() -> None:
    code = (
        "import sys\n"
        "import jetson.cli, jetson.perception.pipeline, jetson.perception.cnn.runtime\n"
        "import jetson.perception.sources, jetson.perception.calibrate\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
        "assert not any(m == 'sim' or m.startswith('sim.') for m in sys.modules)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_the_stream_server_needs_only_numpy() -> None:
    code = (
        "import sys\n"
        "from jetson.perception.sources.stream import FrameStreamServer\n"
        "assert 'cv2' not in sys.modules and 'torch' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
