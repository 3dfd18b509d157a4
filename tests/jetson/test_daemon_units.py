"""The daemon's pieces on their own: handshake rules, the decision, settings, the policy reader,
the log. No ports, no threads (the link tests are test_daemon_fake_brain.py and
test_daemon_brain_host.py)."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from jetson.autonomy.policy import OnnxPolicy
from jetson.autonomy.spec import ObservationSpec
from jetson.decide import (
    UNCERTAIN_SPEED_MIN,
    Decider,
    PerceptionInput,
    PoseHistory,
    pose_speed_scale,
)
from jetson.errors import PolicyError, SettingsError
from jetson.handshake import Handshake, LinkState
from jetson.log import EventLog, LatencyStats, percentile
from jetson.replay import recorded_decision
from jetson.settings import DecisionConfig, Settings
from jetson.testing import ProbePolicy, write_mlp_policy
from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
    Alliance,
    GpsStatus,
    Hello,
    MatchPeriod,
    MatchPhase,
    PoseFix,
    Role,
    State,
)

SPEC = ObservationSpec()
UNIT = SPEC.length_unit_m


def brain_hello(boot_id: int = 0xB00, fingerprint: int = FINGERPRINT) -> Hello:
    return Hello(fingerprint, PROTOCOL_VERSION, Role.BRAIN, boot_id, "0.1.0")


def state(t_ms: int = 0, **kw) -> State:
    base = dict(
        seq=t_ms // 20 + 1, time_ms=t_ms, phase=MatchPhase.AUTONOMOUS, phase_ms=t_ms,
        alliance=Alliance.RED, x=0.5, y=-0.5, heading=90.0, gps_error=0.01,
        gps_status=GpsStatus.OK, pose_fix=PoseFix.GPS, pose_std=0.01, heading_std=0.5,
    )  # fmt: skip
    base.update(kw)
    return State(**base)


def rings(n: int, age_s: float = 0.05, pid: int = 1) -> PerceptionInput:
    xy = np.array([[0.1 * i, 0.5 + 0.1 * i] for i in range(n)], dtype=np.float64)
    return PerceptionInput(pid, age_s, xy.reshape(-1, 2))


# --- handshake ----------------------------------------------------------------------------------


def test_hello_goes_out_at_once_then_every_period_until_the_brain_matches() -> None:
    h = Handshake(0x1234, "0.1.0", hello_period_s=0.2)
    assert h.due(0.0)
    h.sent(0.0)
    assert not h.due(0.19) and h.due(0.2)
    assert h.hello().role is Role.JETSON and h.hello().fingerprint == FINGERPRINT
    out = h.on_hello(brain_hello(), 0.05)
    assert h.state is LinkState.UP and out.kind == "up"
    assert not out.reply  # ours went out 50 ms ago: the Brain has it or will answer it
    assert not h.due(10.0)  # up: no more Hellos


def test_a_lost_hello_is_repeated_when_the_brain_keeps_asking() -> None:
    h = Handshake(0x1234, "0.1.0", hello_period_s=0.2)
    h.sent(0.0)
    h.on_hello(brain_hello(), 0.01)
    # The Brain sends Hello every 200 ms while it has not seen ours: answer those.
    assert h.on_hello(brain_hello(), 0.25).reply
    h.sent(0.25)
    # ... but not the answer to the one we just sent: that would ping-pong forever.
    assert not h.on_hello(brain_hello(), 0.26).reply


def test_a_fingerprint_mismatch_is_refused_naming_both_and_hellos_slow_down() -> None:
    h = Handshake(0x1234, "0.1.0", hello_period_s=0.2, mismatch_period_s=1.0)
    h.sent(0.0)
    out = h.on_hello(brain_hello(fingerprint=0x12345678), 0.01)
    assert out.kind == "mismatch" and h.state is LinkState.MISMATCH and not h.up
    assert "0x12345678" in out.message and f"0x{FINGERPRINT:08X}" in out.message
    assert out.reply  # a new Brain: tell it who we are, so that its log says why too
    assert not h.due(0.5) and h.due(1.0)
    again = h.on_hello(brain_hello(fingerprint=0x12345678), 0.3)
    assert again.kind == "same" and not again.reply
    # Re-flashed with our schema (new boot id): the link comes up.
    assert h.on_hello(brain_hello(boot_id=0xB01), 2.0).kind == "up" and h.up


def test_a_new_boot_id_while_up_is_a_restart_answered_at_once() -> None:
    h = Handshake(0x1234, "0.1.0")
    h.sent(0.0)
    h.on_hello(brain_hello(0xB00), 0.01)
    h.sent(0.01)
    out = h.on_hello(brain_hello(0xB01), 0.02)
    assert out.kind == "restart" and out.reply and h.brain_boot_id == 0xB01


def test_our_own_hello_echoed_back_is_refused() -> None:
    h = Handshake(0x1234, "0.1.0")
    out = h.on_hello(h.hello(), 0.0)
    assert out.kind == "refused" and "echo" in out.message and h.state is LinkState.WAITING


# --- decision -----------------------------------------------------------------------------------


def test_the_policy_drives_only_in_allowed_phases() -> None:
    policy = ProbePolicy()
    d = Decider(policy, DecisionConfig(drive_phases=("autonomous",)))
    stopped = d.decide(state(phase=MatchPhase.DISABLED), None)
    assert (stopped.linear, stopped.angular, stopped.intake) == (0.0, 0.0, False)
    assert stopped.reason == "phase disabled" and policy.calls == 0
    assert d.decide(state(phase=MatchPhase.DRIVER), None).reason == "phase driver"
    drove = d.decide(state(), None)
    assert drove.drove and policy.calls == 1
    assert drove.linear == pytest.approx(0.5 / UNIT * 0.5, rel=1e-6)
    assert drove.intake  # a policy without an intake action had it always on in training


def test_stale_or_missing_perception_is_seen_as_no_rings() -> None:
    d = Decider(ProbePolicy(), DecisionConfig(perception_max_age_s=0.2))
    fresh = d.decide(state(0), rings(3, age_s=0.1))
    assert fresh.perception == "fresh" and fresh.rings == 3
    assert fresh.angular == pytest.approx(3 / 10 * 2.0)
    stale = d.decide(state(20), rings(3, age_s=0.25))
    assert stale.perception == "stale" and stale.rings == 0 and stale.angular == 0.0
    assert stale.drove  # still driving, as trained for a robot that sees no rings
    none = d.decide(state(40), None)
    assert none.perception == "none" and none.angular == 0.0 and none.drove


def test_observation_is_sim_observation_in_the_alliance_frame() -> None:
    policy = ProbePolicy()
    policy.keep_observations = True
    d = Decider(policy)
    d.decide(state(0, alliance=Alliance.BLUE, x=0.5, phase_ms=21_000), rings(2))
    obs = policy.observations[-1]
    assert obs.shape == (SPEC.size,) and obs.dtype == np.float32
    assert obs[0] == pytest.approx(21.0 / 105.0)
    assert obs[1] == pytest.approx(-0.5 / UNIT)  # blue sees the field turned 180 degrees
    slots = obs[SPEC.ring_offset : SPEC.frame_size].reshape(10, 3)
    assert np.allclose(slots[0], [0.0, 0.5 / UNIT, 1.0]) and slots[2:, 2].sum() == 0


def test_rings_held_come_from_the_brains_counter_or_the_configured_stand_in() -> None:
    policy = ProbePolicy()
    policy.keep_observations = True
    d = Decider(policy, DecisionConfig(rings_held=2))
    d.decide(state(0, rings_held=255), None)  # 255: the Brain has no ring counter
    assert policy.observations[-1][5] == pytest.approx(2 / SPEC.ring_capacity_norm)
    d.decide(state(20, rings_held=7), None)
    assert policy.observations[-1][5] == pytest.approx(7 / SPEC.ring_capacity_norm)


def test_frames_enter_the_stack_at_the_policys_control_rate() -> None:
    policy = ProbePolicy()
    policy.keep_observations = True
    d = Decider(policy, DecisionConfig(decision_hz=12.0))
    fs = SPEC.frame_size
    for t in range(0, 1000, 20):  # 50 Hz States for one second, x = t mm
        d.decide(state(t, x=t / 1000.0), None)
    history = [round(float(o[fs + 1]) * UNIT * 1000) for o in policy.observations]
    current = [round(float(o[1]) * UNIT * 1000) for o in policy.observations]
    assert current == list(range(0, 1000, 20))  # every State is answered from its own pose
    # The frame before the current one moves on only when the stack commits a frame, every
    # 1/12 s on the Brain's clock (pushes at 100, 180, 260, ... ms), and holds the frame committed
    # at the push before: its age stays within one to two control periods, as in training.
    changes = [(20 * i, history[i]) for i in range(1, len(history)) if history[i] != history[i - 1]]
    commits = [next(t for t in range(0, 1000, 20) if t >= k * 1000 / 12) for k in range(1, 12)]
    assert commits[:4] == [100, 180, 260, 340]
    assert changes == list(zip(commits[1:], commits[:-1], strict=True))


def test_a_new_enable_or_a_restarted_phase_starts_a_fresh_history() -> None:
    policy = ProbePolicy()
    policy.keep_observations = True
    d = Decider(policy)
    fs = SPEC.frame_size
    for t in range(0, 400, 20):
        d.decide(state(t, x=t / 1000.0), None)
    assert policy.observations[-1][fs + 1] != policy.observations[-1][1]
    d.decide(state(400, phase=MatchPhase.DISABLED, phase_ms=0), None)
    d.decide(state(420, x=0.9, phase_ms=0), None)  # enabled again
    obs = policy.observations[-1]
    assert np.all(obs.reshape(11, fs) == obs[:fs])  # every slot holds the first frame
    d.decide(state(440, x=0.1, phase_ms=20), None)
    d.decide(state(460, x=0.3, phase_ms=0), None)  # phase clock went back: re-enabled
    obs = policy.observations[-1]
    assert np.all(obs.reshape(11, fs) == obs[:fs])


def test_autonomous_into_driver_keeps_the_match_history() -> None:
    policy = ProbePolicy()
    policy.keep_observations = True
    d = Decider(policy, DecisionConfig(driver_time_offset_s=15.0))
    fs = SPEC.frame_size
    for t in range(0, 200, 20):
        d.decide(state(t, x=t / 1000.0), None)
    d.decide(state(200, x=0.2, phase=MatchPhase.DRIVER, phase_ms=0), None)
    obs = policy.observations[-1]
    assert obs[fs + 1] != obs[1]  # history kept
    assert obs[0] == pytest.approx(15.0 / 105.0)  # the match clock continues


def test_a_gps_dropout_is_driven_through_slower_as_the_brains_trust_wears() -> None:
    d = Decider(ProbePolicy(), DecisionConfig(pose_max_std_m=0.15))
    ok = d.decide(state(pose_fix=PoseFix.GPS, pose_std=0.01), None)
    assert ok.drove and ok.linear != 0.0
    for status in (GpsStatus.ERROR, GpsStatus.CALIBRATING, GpsStatus.ABSENT):
        dropout = d.decide(state(gps_status=status, pose_fix=PoseFix.ODOMETRY, pose_std=0.08), None)
        assert dropout.drove and dropout.linear == pytest.approx(ok.linear), status
    # Beyond pose_max_std_m it drives on, slower: 0.15 / 0.2 of the speed, never below half.
    odometry = {"gps_status": GpsStatus.ERROR, "pose_fix": PoseFix.ODOMETRY}
    worn = d.decide(state(pose_std=0.2, **odometry), None)
    assert worn.drove and worn.reason == "policy"
    assert worn.linear == pytest.approx(0.75 * ok.linear)
    very = d.decide(state(pose_std=0.9, **odometry), None)
    assert very.drove and very.linear == pytest.approx(UNCERTAIN_SPEED_MIN * ok.linear)
    # Only the Brain's "lost" (no pose, or its trust run out) is a stop.
    lost = d.decide(state(pose_fix=PoseFix.LOST, pose_std=0.0), None)
    assert not lost.drove and lost.reason == "pose lost"
    # The limit is a setting: a stricter one slows sooner.
    strict = DecisionConfig(pose_max_std_m=0.05)
    assert pose_speed_scale(state(pose_fix=PoseFix.ODOMETRY, pose_std=0.08), strict) == 0.625
    assert pose_speed_scale(state(pose_fix=PoseFix.GPS, pose_std=0.01), strict) == 1.0


def test_the_role_is_a_setting_checked_and_reported() -> None:
    assert DecisionConfig().role == "24in"
    assert DecisionConfig(role="15in").role == "15in"
    with pytest.raises(SettingsError, match="decision role must be one of 24in, 15in"):
        DecisionConfig(role="18in")
    settings = Settings.from_dict({"decision": {"role": "15in"}})
    assert settings.decision.role == "15in"


@pytest.mark.parametrize("bad", [0.0, -0.1, 3.0, float("nan"), "0.1", True])
def test_pose_max_std_must_be_a_sane_number(bad: object) -> None:
    with pytest.raises(SettingsError, match="pose_max_std_m"):
        DecisionConfig(pose_max_std_m=bad)  # type: ignore[arg-type]


def test_the_disable_between_isolation_and_interaction_keeps_the_match_history() -> None:
    policy = ProbePolicy()
    policy.keep_observations = True
    d = Decider(policy, DecisionConfig(driver_time_offset_s=15.0))
    fs = SPEC.frame_size
    for t in range(0, 200, 20):
        d.decide(state(t, x=t / 1000.0, period=MatchPeriod.ISOLATION), None)
    resets: list[str] = []
    d.ring_memory.reset = lambda: resets.append("rings")  # type: ignore[method-assign]
    d.goal_memory.reset = lambda: resets.append("goals")  # type: ignore[method-assign]
    for t in range(200, 3200, 20):  # the field disables the robots between the periods
        pause = state(t, phase=MatchPhase.DISABLED, phase_ms=t - 200, period=MatchPeriod.PAUSE)
        assert d.decide(pause, None).reason == "phase disabled"
    interaction = state(
        3200, x=0.2, phase=MatchPhase.DRIVER, phase_ms=0, period=MatchPeriod.INTERACTION
    )
    assert d.decide(interaction, None).drove
    obs = policy.observations[-1]
    assert obs[fs + 1] != obs[1]  # the frame history kept
    assert resets == []  # the ring and goal memories kept
    assert obs[0] == pytest.approx(15.0 / 105.0)
    # A new match (autonomous again after the interaction) starts afresh.
    d.decide(state(9000, phase=MatchPhase.DISABLED, phase_ms=0), None)
    d.decide(state(9020, x=0.9, phase_ms=0, period=MatchPeriod.ISOLATION), None)
    obs = policy.observations[-1]
    assert np.all(obs.reshape(11, fs) == obs[:fs])
    assert resets == ["rings", "goals"]


def test_any_exception_or_bad_output_is_a_stop_and_the_next_state_drives_again() -> None:
    policy = ProbePolicy()
    d = Decider(policy)
    policy.fail = lambda obs: True
    failed = d.decide(state(0), None)
    assert (failed.linear, failed.angular, failed.intake, failed.reason) == (0, 0, False, "error")
    assert "probe policy told to fail" in failed.error
    policy.fail = None
    assert d.decide(state(20), None).drove
    bad_rings = PerceptionInput(2, 0.0, np.array([[np.nan, 1.0]]))
    broken = d.decide(state(40), bad_rings)
    assert broken.reason == "error" and "NaN" in broken.error

    class NanPolicy(ProbePolicy):
        def __call__(self, obs):
            return np.array([np.nan, 0.0], dtype=np.float32)

    assert Decider(NanPolicy()).decide(state(0), None).reason == "policy output not finite"


def test_perception_that_raised_on_the_newest_frame_is_a_stop_until_it_ages_out() -> None:
    policy = ProbePolicy()
    d = Decider(policy, DecisionConfig(perception_max_age_s=0.2))
    broken = PerceptionInput(3, 0.05, np.zeros((0, 2)), "ValueError: bad depth")
    got = d.decide(state(0), broken)
    assert (got.linear, got.angular, got.intake) == (0.0, 0.0, False)
    assert got.reason == "perception error" and got.error == "ValueError: bad depth"
    assert policy.calls == 0
    # The camera then stops delivering: an old error is just no rings, as trained.
    old = d.decide(state(20), PerceptionInput(3, 0.5, np.zeros((0, 2)), "ValueError: bad depth"))
    assert old.drove and old.perception == "stale"


def test_sync_perception_publishes_an_exception_as_an_error_result() -> None:
    from jetson.camera_feed import SyncPerception
    from jetson.clock import ManualClock

    def process(frame):
        if frame.bad:
            raise ValueError("bad depth")
        return SimpleNamespace(rings_robot_xy=[[0.0, 1.0]], detections=[1])

    feed = SyncPerception(process, ManualClock(5.0))
    good = feed.submit(SimpleNamespace(bad=False, index=1))
    assert good.error is None and good.rings_robot_xy.shape == (1, 2) and good.detections == 1
    bad = feed.submit(SimpleNamespace(bad=True, index=2))
    assert bad.error == "ValueError: bad depth" and len(bad.rings_robot_xy) == 0
    assert bad.stamp_s == 5.0 and feed.latest() is bad


def test_no_gps_fix_or_no_alliance_is_a_stop_with_the_reason() -> None:
    d = Decider(ProbePolicy())
    no_fix = state(gps_status=GpsStatus.CALIBRATING, pose_fix=PoseFix.LOST, pose_std=0.0)
    assert d.decide(no_fix, None).reason == "gps calibrating"
    unknown = d.decide(state(alliance=Alliance.UNKNOWN), None)
    assert not unknown.drove and "alliance" in unknown.reason


def test_an_intake_action_drives_the_intake() -> None:
    class IntakePolicy(ProbePolicy):
        action_names = ("linear", "angular", "intake")
        action_scale = (0.5, 2.0, 1.0)

        def __call__(self, obs):
            return np.array([0.1, 0.0, 1.0 if obs[1] > 0 else -1.0], dtype=np.float32)

    d = Decider(IntakePolicy())
    assert d.decide(state(0, x=0.5), None).intake
    assert not d.decide(state(20, x=-0.5), None).intake


# --- settings -----------------------------------------------------------------------------------


def test_settings_file_round_trip_and_errors_name_the_key(tmp_path: Path) -> None:
    good = tmp_path / "good.toml"
    good.write_text(
        '[link]\nport = "/dev/pete-brain"\n[decision]\ndrive_phases = ["autonomous"]\n'
        'perception_max_age_s = 0.5\n[record]\ndir = ""\n'
    )
    s = Settings.load(good)
    assert s.link.port == "/dev/pete-brain" and s.decision.drive_phases == ("autonomous",)
    assert s.decision.perception_max_age_s == 0.5 and not s.record.dir
    assert s.with_overrides(link={"port": "/dev/x", "baud": None}).link.port == "/dev/x"
    bad = tmp_path / "bad.toml"
    for text, needle in (
        ("[link]\nprot = 1\n", "'prot'"),
        ("[linc]\n", "[linc]"),
        ('[decision]\ndrive_phases = ["disabled"]\n', "'disabled'"),
        ("[decision]\nvalid_ms = 5000\n", "valid_ms"),
        ("[link]\nreconnect_poll_s = 3\n", "within 1 s"),
        ("[link\n", "bad.toml"),
    ):
        bad.write_text(text)
        with pytest.raises(SettingsError, match=needle.replace("[", r"\[")):
            Settings.load(bad)


def test_the_shipped_example_config_loads() -> None:
    example = Path(__file__).resolve().parents[2] / "jetson" / "deploy" / "pete-jetson.toml"
    s = Settings.load(example)
    assert s.link.port == "/dev/pete-brain" and s.record.dir


# --- policy file --------------------------------------------------------------------------------


def test_a_tampered_or_missing_policy_is_refused_by_name(tmp_path: Path) -> None:
    path = write_mlp_policy(tmp_path)
    meta = json.loads(path.with_suffix(".json").read_text())
    with pytest.raises(PolicyError, match="no policy"):
        OnnxPolicy(tmp_path / "nope.onnx")
    edited = dict(meta, observation=dict(meta["observation"], n_rings=5))
    path.with_suffix(".json").write_text(json.dumps(edited))
    with pytest.raises(PolicyError, match="fingerprint"):
        OnnxPolicy(path)
    path.with_suffix(".json").write_text(json.dumps(dict(meta, onnx_sha256="0" * 64)))
    with pytest.raises(PolicyError, match="onnx_sha256"):
        OnnxPolicy(path)
    path.with_suffix(".json").unlink()
    with pytest.raises(PolicyError, match="metadata"):
        OnnxPolicy(path)


# --- log ----------------------------------------------------------------------------------------


def test_log_lines_are_json_with_the_fixed_keys_and_the_summary_goes_to_both() -> None:
    out, human = io.StringIO(), io.StringIO()
    log = EventLog(out, human, min_level="info")
    log.debug("noise", "not shown")
    log.warning("link_down", "link down", n=np.int64(3), xs=np.array([1.5, np.nan]))
    log.summary("up | 50 Hz", rate_hz=50.0)
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    assert [r["event"] for r in lines] == ["link_down", "summary"]
    assert {"ts", "t", "level", "event", "msg"} <= set(lines[0])
    assert lines[0]["n"] == 3 and lines[0]["xs"] == [1.5, None]
    assert human.getvalue() == "up | 50 Hz\n"


def test_latency_percentiles() -> None:
    values = sorted(i / 1000 for i in range(1, 101))
    assert percentile(values, 50) == 0.05 and percentile(values, 99) == 0.099
    stats = LatencyStats()
    for v in values:
        stats.add(v)
    s = LatencyStats.summary_ms(stats.take_window())
    assert s["n"] == 100 and s["p99_ms"] == pytest.approx(99.0) and stats.window == []
    assert LatencyStats.summary_ms([])["n"] == 0


def test_the_configured_intake_reaches_a_policy_that_reads_it() -> None:
    spec = ObservationSpec(version=5, intake_flag=True, n_stack=0)
    fills = spec.scalar_index("fills")
    for configured, expected in ((True, 1.0), (False, 0.0)):
        policy = ProbePolicy(spec)
        policy.keep_observations = True
        Decider(policy, DecisionConfig(intake_fills=configured)).decide(state(0), None)
        assert policy.observations[-1][fills] == expected


def test_decision_config_is_checked() -> None:
    with pytest.raises(SettingsError, match="perception_max_age_s"):
        DecisionConfig(perception_max_age_s=0)
    with pytest.raises(SettingsError, match="intake_fills must be true or false"):
        DecisionConfig(intake_fills="no")  # type: ignore[arg-type]
    assert replace(DecisionConfig(), valid_ms=100).valid_ms == 100


# --- finding the port -----------------------------------------------------------------------------


def test_the_port_is_the_user_port_found_over_usb_never_the_system_port(tmp_path: Path) -> None:
    from jetson.link import PortLocator
    from jetson.ports import V5Port

    ports: list[V5Port] = []
    scans = []

    def discover() -> list[V5Port]:
        scans.append(1)
        return list(ports)

    loc = PortLocator(discover=discover, scan_interval_s=0.0)
    assert loc.find() is None
    ports[:] = [V5Port("/dev/ttyACM0", "system", "VEX V5 Brain System")]
    assert loc.find() is None  # uploads go there: never talk on it
    ports.append(V5Port("/dev/ttyACM1", "user", "VEX V5 Brain User"))
    assert loc.find() == "/dev/ttyACM1"
    slow = PortLocator(discover=discover, scan_interval_s=60.0)
    n = len(scans)
    assert slow.find() == slow.find() == "/dev/ttyACM1" and len(scans) == n + 1
    fixed = PortLocator(str(tmp_path / "pete-brain"))
    assert fixed.find() is None
    (tmp_path / "pete-brain").touch()
    assert fixed.find() == str(tmp_path / "pete-brain")


def test_the_port_is_opened_raw_and_a_hang_up_is_link_closed() -> None:
    import os
    import pty
    import termios

    from jetson.link import LinkClosed, SerialLink

    master, slave = pty.openpty()  # a cooked tty, as a fresh /dev/ttyACM is: echo, CR/LF maps
    path = os.ttyname(slave)
    os.close(slave)
    link = SerialLink.open(path)
    try:
        iflag, oflag, _, lflag, _, _, _ = termios.tcgetattr(link.fileno())
        assert not lflag & (termios.ECHO | termios.ICANON | termios.ISIG)
        assert not oflag & termios.OPOST and not iflag & (termios.ICRNL | termios.IXON)
        payload = bytes(range(256))  # every byte value crosses unchanged, both ways
        os.write(master, payload)
        got = b""
        while len(got) < 256:
            got += link.read(1.0)
        assert got == payload and link.rx_bytes == 256
        assert link.write(b":0102\r\n") and os.read(master, 100) == b":0102\r\n"
        os.close(master)  # the Brain goes away
        with pytest.raises(LinkClosed):
            for _ in range(10):
                link.read(0.1)
    finally:
        link.close()
    with pytest.raises(LinkClosed, match="does not exist"):
        SerialLink.open("/dev/pete-brain-that-is-not-there")


def test_the_summary_line_says_what_a_person_needs_first() -> None:
    from jetson.stats import Snapshot, summary_fields, summary_line
    from protocol.messages import Command

    lat = LatencyStats.summary_ms([0.0002, 0.0004, 0.0009])
    base = dict(
        link="up", port="/dev/pete-brain", waited_s=0.0, brain_boot_id=0x5EED0001,
        state=state(12_300), rate_hz=50.0, latency=lat, received=616, lost=2,
        errors={"bad_crc": 1, "truncated": 1}, perception=(4, 0.035), has_perception=True,
        command=Command(9, 0.61, -0.2, True, 250), stop_reason=None, window={}, counters={},
    )  # fmt: skip
    up = Snapshot(**base)
    assert summary_line(up) == (
        "up brain 5EED0001 | red | autonomous 12.3 s | pose gps 0.01 m | 50 Hz"
        " | latency p50 0.40 p99 0.90 max 0.90 ms"
        " | rx 616 lost 2 | errors bad_crc=1 truncated=1 | rings 4 (35 ms old)"
        " | cmd +0.61 m/s -0.20 rad/s intake"
    )
    # The robot's role, the match period and a pose riding through a GPS dropout.
    dropout = state(12_300, period=MatchPeriod.ISOLATION, pose_fix=PoseFix.ODOMETRY, pose_std=0.083)
    playing = Snapshot(**{**base, "state": dropout, "role": "15in"})
    assert summary_line(playing).startswith(
        "up brain 5EED0001 | red 15in | autonomous 12.3 s (isolation) | pose odometry 0.08 m |"
    )
    fields = summary_fields(playing)
    assert fields["role"] == "15in" and fields["alliance"] == "red"
    assert fields["period"] == "isolation"
    assert fields["pose"] == {"fix": "odometry", "std_m": 0.083}
    assert summary_fields(up)["perception"] == {"rings": 4, "age_ms": 35.0}
    stopped = Snapshot(
        **{**base, "command": Command(9, 0, 0, False, 250), "stop_reason": "gps error"}
    )
    assert summary_line(stopped).endswith("cmd +0.00 m/s +0.00 rad/s (gps error)")
    idle = {"link": "waiting for port", "waited_s": 12.4, "rate_hz": 0.0, "errors": {}}
    idle.update(latency=LatencyStats.summary_ms([]), perception=None)
    waiting = Snapshot(**{**base, **idle})
    assert summary_line(waiting) == (
        "waiting for the Brain at /dev/pete-brain (12 s) | 0 Hz | rx 616 lost 2 | errors none"
        " | no perception"
    )
    assert summary_line(Snapshot(**{**base, "link": "mismatch"})).startswith("SCHEMA MISMATCH")


def test_a_ring_memory_policy_remembers_through_a_stale_camera_and_forgets_on_a_fresh_one() -> None:
    # Red robot at (0.5, -0.5) facing +x: prior ring A 1 m ahead (in view), B 1 m behind.
    spec = ObservationSpec(ring_memory=True, prior_rings=((1.5, -0.5), (-0.5, -0.5)), n_stack=0)
    policy = ProbePolicy(spec)
    policy.keep_observations = True
    d = Decider(policy, DecisionConfig(perception_max_age_s=0.2))

    def oks() -> list[float]:
        obs = policy.observations[-1]
        return sorted(obs[spec.ring_offset + 2 : spec.frame_size : 3].tolist(), reverse=True)

    d.decide(state(0), None)  # no camera yet: both prior rings remembered
    assert oks()[:3] == [0.5, 0.5, 0.0]
    d.decide(state(20), rings(0, age_s=0.5))  # a stale empty picture proves nothing
    assert oks()[:3] == [0.5, 0.5, 0.0]
    d.decide(state(40), rings(0))  # a fresh picture without A: A is gone, B is still behind
    assert oks()[:2] == [0.5, 0.0]
    d.decide(state(60, phase=MatchPhase.DISABLED), None)
    d.decide(state(80), None)  # a new match starts from the layout again
    assert oks()[:3] == [0.5, 0.5, 0.0]


def test_a_goal_memory_policy_reads_the_brains_clamp_and_drops_the_held_goal() -> None:
    # Red robot at (0.5, -0.5) facing +x: goal A right behind its back (the clamp point), B far.
    offset = 0.36
    spec = ObservationSpec(
        goal_memory=True,
        prior_goals=((0.5 - offset, -0.5), (0.5, 1.5)),
        goal_clamp_offset_m=offset,
        n_stack=0,
    )
    policy = ProbePolicy(spec)
    policy.keep_observations = True
    d = Decider(policy)

    def clamped_and_goals() -> tuple[float, int]:
        obs = policy.observations[-1]
        oks = obs[spec.goal_offset + 2 : spec.ring_offset : 3]
        return float(obs[6]), int((oks > 0).sum())

    d.decide(state(0, goal_clamped=0), None)
    assert clamped_and_goals() == (0.0, 2)
    d.decide(state(20, goal_clamped=1), None)
    assert clamped_and_goals() == (1.0, 1), "the held goal leaves the slots"
    d.decide(state(40, goal_clamped=255), None)  # a Brain without a clamp sensor reads as open
    assert clamped_and_goals()[0] == 0.0


def test_a_skill_policy_is_driven_by_the_skill_controller() -> None:
    from jetson.autonomy.skills import SkillConfig

    spec = ObservationSpec(n_stack=0)
    skills = SkillConfig(ring_options=2, goal_options=0, platform=False)

    class SkillPolicy(ProbePolicy):
        action_names = ("ring0", "ring1")
        action_scale = (1.0, 1.0)

        def __call__(self, obs):
            return np.array([-1.0, 1.0], dtype=np.float32)  # always the second-nearest ring

    policy = SkillPolicy(spec)
    policy.skills = skills
    d = Decider(policy)
    # Rings straight ahead (nearest) and ahead-right (second): the robot turns right to ring1.
    seen = PerceptionInput(1, 0.05, np.array([[0.0, 0.8], [0.5, 1.2]]))
    out = d.decide(state(0), seen)
    assert out.drove and out.linear > 0 and out.angular > 0
    # Only one ring known: the second slot is empty and the robot turns in place, looking.
    out = d.decide(state(100), PerceptionInput(2, 0.05, np.array([[0.0, 0.8]])))
    assert out.linear == 0.0 and out.angular > 0


def test_a_skill_controller_that_raises_is_a_stop_with_the_error() -> None:
    from jetson.autonomy.skills import SkillConfig

    class SkillPolicy(ProbePolicy):
        action_names = ("ring0",)
        action_scale = (1.0,)

        def __call__(self, obs):
            return np.array([1.0, 0.0], dtype=np.float32)

    policy = SkillPolicy(ObservationSpec(n_stack=0))
    policy.skills = SkillConfig(ring_options=2, goal_options=0, platform=False)
    d = Decider(policy)

    def broken(obs, action):
        raise RuntimeError("controller broke")

    d._driver.command = broken  # type: ignore[union-attr]
    out = d.decide(state(0), rings(1))
    assert not out.drove and out.linear == 0.0 and "controller broke" in (out.error or "")


def test_pose_history_interpolates_the_short_way_round_and_forgets_a_reboot() -> None:
    h = PoseHistory(span_ms=100.0)
    assert h.at(0.0) is None
    h.push(0.0, 0.0, 0.0, 350.0)
    h.push(20.0, 1.0, 2.0, 10.0)
    x, y, heading = h.at(10.0)
    assert (x, y) == pytest.approx((0.5, 1.0)) and heading == pytest.approx(0.0, abs=1e-9)
    assert h.at(-5.0) is None and h.at(50.0) == (1.0, 2.0, 10.0)
    for t in range(40, 201, 20):
        h.push(float(t), 0.0, 0.0, 0.0)
    assert h.at(80.0) is None  # older than the span
    h.push(5.0, 3.0, 3.0, 0.0)  # the Brain's clock went back
    assert h.at(5.0) == (3.0, 3.0, 0.0) and h.at(4.0) is None


def test_a_frame_taken_before_a_turn_is_placed_from_the_pose_it_was_taken_at() -> None:
    # Red robot at (0.5, -0.5): facing +x (heading 90) until t=20, turning at 300 deg/s after.
    # Prior ring A 1 m ahead of the first pose; the frame taken at t=20 shows it straight ahead.
    spec = ObservationSpec(ring_memory=True, prior_rings=((1.5, -0.5),), n_stack=0)

    def run(frame_pose: bool) -> tuple[np.ndarray, np.ndarray]:
        policy = ProbePolicy(spec)
        policy.keep_observations = True
        d = Decider(policy, DecisionConfig(frame_pose=frame_pose))
        for t in range(0, 121, 20):
            heading = 90.0 + max(0, t - 20) * 0.3
            frame = PerceptionInput(1, (t - 20) / 1000, np.array([[0.0, 1.0]]))
            d.decide(state(t, heading=heading), frame if t >= 20 else None)
        obs = policy.observations[-1]
        return d._memory.known, obs[spec.ring_offset : spec.frame_size].reshape(-1, 3)

    known, slots = run(frame_pose=True)
    np.testing.assert_allclose(known, [(1.5, -0.5)], atol=1e-9)  # confirmed where it is
    # Seen, and where it is now: 30 degrees left of the nose after turning 30 degrees right.
    h = np.radians(30.0)
    np.testing.assert_allclose(slots[0], [-np.sin(h) / UNIT, np.cos(h) / UNIT, 1.0], atol=1e-6)
    known, _ = run(frame_pose=False)
    assert np.linalg.norm(known - (1.5, -0.5), axis=1).min() > 0.4, "placed 30 degrees off"


def test_a_recording_from_before_frame_pose_replays_with_the_newest_pose() -> None:
    now = DecisionConfig(intake_fills=False).to_dict()
    assert recorded_decision({"decision": now, "decision_hz": 12.0}).frame_pose is True
    old = {k: v for k, v in now.items() if k != "frame_pose"}
    config = recorded_decision({"decision": old, "decision_hz": 12.0})
    assert config.frame_pose is False and config.intake_fills is False
    assert config.decision_hz == 12.0


def test_a_camera_view_memory_policy_forgets_only_what_the_configured_camera_shows() -> None:
    # memory_view "camera": the daemon looks through [camera]'s mount and intrinsics (here the
    # defaults, 0.3 m up and tilted 30 deg down: the floor shows to ~2.1 m). Red robot at
    # (0.5, -0.5) facing +x; prior ring A 1.2 m ahead, C 2.4 m ahead (above the picture), B behind.
    from jetson.errors import ObservationError
    from jetson.service import memory_camera
    from jetson.settings import CameraSettings

    prior = ((1.7, -0.5), (2.9, -0.5), (-0.5, -0.5))
    spec = ObservationSpec(ring_memory=True, prior_rings=prior, n_stack=0, memory_view="camera")
    policy = ProbePolicy(spec)
    policy.keep_observations = True
    with pytest.raises(ObservationError, match="memory_view"):
        Decider(policy, DecisionConfig())
    d = Decider(policy, DecisionConfig(perception_max_age_s=0.2), memory_camera(CameraSettings()))
    d.decide(state(0), rings(0))  # a fresh empty picture: A is gone, C and B are not in it

    def oks() -> list[float]:
        obs = policy.observations[-1]
        return sorted(obs[spec.ring_offset + 2 : spec.frame_size : 3].tolist(), reverse=True)

    assert oks()[:3] == [0.5, 0.5, 0.0]
    cone = ProbePolicy(replace(spec, memory_view="cone"))
    cone.keep_observations = True
    Decider(cone, DecisionConfig(perception_max_age_s=0.2)).decide(state(0), rings(0))
    obs = cone.observations[-1]
    assert sorted(obs[spec.ring_offset + 2 : spec.frame_size : 3].tolist())[-2:] == [0.0, 0.5]
