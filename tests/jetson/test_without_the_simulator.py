"""The robot's side runs with the simulator and the training stack out of reach: what a Jetson
that installed only the `jetson` extra has. tests/test_layering.py states the rule over the
source; these run it."""

from __future__ import annotations

import subprocess
import sys

# Blocked modules: importing one raises ImportError, as on a Jetson without them.
BLOCKED = ("sim", "torch", "pybullet", "gymnasium", "pettingzoo", "matplotlib", "tensorboard")
PRELUDE = "import sys\n" + "".join(f"sys.modules[{name!r}] = None\n" for name in BLOCKED)


def run(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", PRELUDE + code],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_the_daemon_and_the_decision_code_import_without_the_simulator() -> None:
    out = run(
        "import jetson.service, jetson.loop, jetson.replay, jetson.decide, jetson.camera_feed\n"
        "import jetson.autonomy.policy, jetson.autonomy.ring_memory, jetson.autonomy.goal_memory\n"
        "import jetson.perception.pipeline\n"
        "from jetson.service import build\n"
        "print('imported')\n"
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "imported"


def test_pete_jetson_run_help_works_without_the_simulator() -> None:
    out = run("from jetson.cli import main\nsys.exit(main(['run', '--help']))\n")
    assert out.returncode == 0, out.stderr
    assert "usage: pete-jetson run" in out.stdout


def test_the_shipped_policy_loads_and_runs_without_the_simulator() -> None:
    """The one policy reader opens the shipped policies (the robot's and the learned
    alliance's) and gives a finite action."""
    out = run(
        "import numpy as np\n"
        "from jetson.autonomy.policy import OnnxPolicy\n"
        "from jetson.models import ALLIANCE_POLICY, DEFAULT_POLICY\n"
        "for path in (DEFAULT_POLICY, ALLIANCE_POLICY):\n"
        "    policy = OnnxPolicy(path)\n"
        "    action = policy(np.zeros(policy.spec.size, np.float32))\n"
        "    assert action.shape == (len(policy.action_names),) and np.all(np.isfinite(action))\n"
        "print('ok')\n"
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_the_block_is_real() -> None:
    """A module this test blocks cannot be imported, so the tests above prove something."""
    out = run("import sim.match\n")
    assert out.returncode != 0 and "ModuleNotFoundError" in out.stderr
