"""The systemd unit is hardened, systemd rates it (`python -m bench.deploy`), and it agrees with
install.sh and the shipped settings on users, paths and what the daemon may touch."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from bench import deploy
from jetson.settings import Settings

DEPLOY = Path(__file__).resolve().parents[2] / "jetson" / "deploy"
UNIT = DEPLOY / "pete-jetson.service"
needs_systemd_analyze = pytest.mark.skipif(
    shutil.which("systemd-analyze") is None,
    reason="systemd-analyze is not installed (it comes with systemd)",
)


def unit_settings(path: Path = UNIT) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for line in path.read_text().splitlines():
        line = line.strip()
        if line and not line.startswith(("#", "[")):
            key, _, value = line.partition("=")
            out.setdefault(key, []).append(value)
    return out


@needs_systemd_analyze
def test_systemd_rates_the_unit_ok(tmp_path: Path) -> None:
    rating = deploy.rate(UNIT)
    assert rating.exposure <= deploy.TARGET, rating
    assert rating.label == "OK"
    # The same check fails on a unit with no hardening (what the unit was before).
    bare = tmp_path / "bare.service"
    bare.write_text("[Service]\nUser=pete\nExecStart=/opt/pete/.venv/bin/pete-jetson run\n")
    assert deploy.rate(bare).exposure > 9.0


def test_the_bench_names_a_missing_systemd_analyze(monkeypatch, capsys, tmp_path) -> None:
    monkeypatch.setattr(deploy.shutil, "which", lambda name: None)
    monkeypatch.setattr(deploy.Result, "save", lambda *a, **k: pytest.fail("wrote a result"))
    assert deploy.main([]) == 0, "make bench goes on without it"
    assert "skipped: systemd-analyze is not installed" in capsys.readouterr().err
    assert deploy.main(["--unit", str(tmp_path / "none.service")]) == 2
    assert "no unit file" in capsys.readouterr().err


def test_the_unit_takes_away_what_the_daemon_does_not_use() -> None:
    u = unit_settings()
    for key, value in {
        "NoNewPrivileges": "yes",
        "ProtectSystem": "strict",
        "PrivateTmp": "yes",
        "ProtectHome": "yes",
        "DevicePolicy": "closed",
        "CapabilityBoundingSet": "",
        "RestrictNamespaces": "yes",
        "LockPersonality": "yes",
        "MemoryDenyWriteExecute": "yes",
        "SystemCallFilter": "@system-service",
        "ProtectKernelTunables": "yes",
        "ProtectKernelModules": "yes",
        "ProtectKernelLogs": "yes",
    }.items():
        assert u.get(key) == [value], key
    devices = {d.split()[0] for d in u["DeviceAllow"]}
    assert {"char-ttyACM", "char-video4linux", "char-usb_device"} <= devices
    families = u["RestrictAddressFamilies"][0].split()
    assert "AF_UNIX" in families and not {"AF_INET", "AF_INET6", "AF_PACKET"} & set(families)
    assert "ReadWritePaths" not in u, "the writable places are the State/Logs/Cache directories"
    assert u["CacheDirectory"] == ["pete-jetson"], "TensorRT's engine cache ($CACHE_DIRECTORY)"


def test_the_installed_settings_stay_inside_what_the_unit_allows() -> None:
    u = unit_settings()
    settings = Settings.load(DEPLOY / "pete-jetson.toml")
    state = Path("/var/lib") / u["StateDirectory"][0]
    logs = Path("/var/log") / u["LogsDirectory"][0]
    assert Path(settings.record.dir).is_relative_to(state)
    # The log file line is commented out (the journal by default); where it points is writable.
    shown = re.search(r'^# file = "([^"]+)"', (DEPLOY / "pete-jetson.toml").read_text(), re.M)
    assert shown is not None and Path(shown.group(1)).is_relative_to(logs)
    # No Internet sockets are allowed: the installed camera source is not a tcp: stream.
    assert not settings.camera.source.startswith("tcp:")
    assert settings.link.port.startswith("/dev/")


def test_install_sh_and_the_unit_agree_on_user_paths_and_groups() -> None:
    u = unit_settings()
    script = (DEPLOY / "install.sh").read_text()
    user = u["User"][0]
    assert u["Group"] == [user]
    useradd = next(x for x in script.splitlines() if x.strip().startswith("useradd"))
    assert useradd.split()[-1] == user
    home = useradd.split("--home-dir")[1].split()[0]
    assert home == u["WorkingDirectory"][0] == f"/var/lib/{u['StateDirectory'][0]}"
    groups = re.search(r"for group in ([\w ]+); do", script)
    assert groups is not None and groups.group(1).split() == u["SupplementaryGroups"][0].split()
    exec_start = u["ExecStart"][0].split()
    assert f"[ ! -x {exec_start[0]} ]" in script
    assert exec_start[exec_start.index("--config") + 1] in script
    assert "/etc/systemd/system/pete-jetson.service" in script
