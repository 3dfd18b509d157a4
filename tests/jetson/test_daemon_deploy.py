"""The deployment files agree with each other and with the daemon: the unit restarts forever and
stops with SIGTERM, the udev rule's name is the port the shipped config uses, and the install
script is valid shell."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from jetson import cli
from jetson.settings import Settings

DEPLOY = Path(__file__).resolve().parents[2] / "jetson" / "deploy"


def unit_settings() -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for line in (DEPLOY / "pete-jetson.service").read_text().splitlines():
        line = line.strip()
        if line and not line.startswith(("#", "[")):
            key, _, value = line.partition("=")
            out.setdefault(key, []).append(value)
    return out


def test_the_unit_restarts_always_and_stops_with_sigterm() -> None:
    unit = unit_settings()
    assert unit["Restart"] == ["always"] and unit["StartLimitIntervalSec"] == ["0"]
    assert unit["KillSignal"] == ["SIGTERM"]
    assert unit["StateDirectory"] == ["pete-jetson"]
    exec_start = unit["ExecStart"][0].split()
    assert exec_start[0].endswith("/pete-jetson") and exec_start[1] == "run"
    config = exec_start[exec_start.index("--config") + 1]
    assert config == "/etc/pete-jetson/pete-jetson.toml"
    assert config in (DEPLOY / "install.sh").read_text()
    # The command line the unit runs is one the daemon accepts.
    args = cli.build_parser().parse_args(exec_start[1:])
    assert args.func.__name__ == "cmd_run"


def test_the_udev_name_is_the_port_the_shipped_config_uses() -> None:
    rule = (DEPLOY / "99-pete-brain.rules").read_text()
    active = [x for x in rule.splitlines() if x and not x.startswith("#")]
    user = next(x for x in active if "SYMLINK" in x)
    assert 'ATTRS{idVendor}=="2888"' in user and 'ENV{ID_USB_INTERFACE_NUM}=="02"' in user
    assert 'SUBSYSTEM=="tty"' in user and 'ENV{ID_MM_DEVICE_IGNORE}="1"' in user
    name = user.split('SYMLINK+="')[1].split('"')[0]
    settings = Settings.load(DEPLOY / "pete-jetson.toml")
    assert settings.link.port == f"/dev/{name}"
    assert settings.record.dir == "/var/lib/pete-jetson/sessions"  # inside StateDirectory


def test_install_script_is_valid_shell() -> None:
    sh = shutil.which("sh")
    assert sh is not None
    subprocess.run([sh, "-n", str(DEPLOY / "install.sh")], check=True, timeout=30)
