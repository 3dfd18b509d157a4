"""What the daemon may import: from the simulator only sim.observation and sim.skills (numpy),
and never torch, PyBullet or Gymnasium, so that the Jetson needs only the `jetson` extra."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

JETSON = Path(__file__).resolve().parents[2] / "jetson"
HEAVY = ("torch", "pybullet", "gymnasium", "pettingzoo", "matplotlib")


def imported_modules(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def test_daemon_modules_import_only_the_observation_skills_and_geometry_from_the_simulator() -> (
    None
):
    files = sorted(JETSON.glob("*.py"))
    assert len(files) >= 12
    # sim.geometry: the numpy frame transforms the observation is built with.
    allowed = ("sim.observation", "sim.skills", "sim.geometry")
    for path in files:
        for mod in imported_modules(path):
            top = mod.split(".")[0]
            if top == "sim":
                assert mod in allowed, f"{path.name} imports {mod}"
            assert top not in HEAVY, f"{path.name} imports {mod}"


def test_the_daemon_loads_without_torch_or_the_simulators_physics() -> None:
    code = (
        "import sys\n"
        "import jetson.service, jetson.loop, jetson.replay, jetson.camera_feed, jetson.policy\n"
        "from jetson.service import build\n"
        "sims = sorted(m for m in sys.modules if m.split('.')[0] == 'sim')\n"
        # sim.route: the numpy-only tour behind the observation's route slots.
        "expected = ['sim', 'sim.geometry', 'sim.observation', 'sim.route', 'sim.skills']\n"
        "assert sims == expected, sims\n"
        f"assert not any(m.split('.')[0] in {HEAVY!r} for m in sys.modules)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
