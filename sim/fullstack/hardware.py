"""The robot's hardware as the Brain sees it, played by the simulator: the bridge World <-> Brain.

Each 10 ms loop step the Brain reads its sensors and drives its motors. Here:

    sensors  (World -> Brain)  the GPS reading (World.gps: the pose `latency_s` ago plus Gaussian
                               noise; with `gps_occlusion`, none while robots, goals or the
                               platform hide the field strip), the wheel encoders (the speeds the
                               robot really moved at over the last step, so a robot pushing a
                               wall reads ~0), the inertial sensor (the robot's cumulative
                               clockwise rotation, with `imu_drift_deg_s` of drift), the
                               intake's ring counter (the rings the robot holds; optional, as on
                               a real robot), the goal clamp's sensor (whether the robot holds a
                               goal at its back; optional too) and the competition status from
                               the match clock;
    motors   (Brain -> World)  the wheel surface speeds the Brain told the drive motors, turned
                               into the simulator's DriveCommand by the robot's track width
                               (DriveCommand.from_wheels), and the intake.

The World's own drive model (acceleration and speed limits of the real robot) then applies them.
The World grabs a goal that touches the back (WorldConfig.auto_clamp); the sensor tells the Brain,
whose own auto close then closes its piston, and the Brain reports it in the State's goal_clamped,
as a real robot's would. When the Brain opens its clamp (the Jetson's Command.clamp release, or
the driver), the World is told to release (DriveCommand.clamp False) and keeps the clamp open
until the Brain closes it again.

Competition status (VEX AI): before the match the robot is powered and disabled (the two sides
connect); the isolation period is autonomous, the interaction period driver control (the Jetson
drives in both: brain/include/pete/core/config.hpp); after the match it is disabled again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.fullstack.brain_host import BrainHost, BrainReport
from sim.world import sensors
from sim.world.physics import World
from sim.world.state import DriveCommand, RobotState


def competition_phase(match_time_s: float, isolation_s: float, started: bool, over: bool) -> str:
    """The competition switch at a moment of the match: disabled / autonomous / driver."""
    if not started or over:
        return "disabled"
    return "autonomous" if match_time_s < isolation_s else "driver"


@dataclass(frozen=True)
class SensorReading:
    """What the Brain's sensors read at one loop step."""

    gps: tuple[float, float, float, float] | None  # x, y, heading (deg cw), error; None: failed
    gps_failure: str | None  # calibrating | error | absent when gps is None
    left_mps: float
    right_mps: float
    phase: str
    rings: int | None = None  # the ring counter; None: no counter fitted
    goal_at_back: bool | None = None  # the clamp's sensor; None: no sensor fitted
    imu_deg: float | None = None  # the IMU's cumulative clockwise rotation; None: no IMU


@dataclass
class PoseTrack:
    """How the Brain's pose (its filter: GPS, odometry, IMU) compared with the truth, per step."""

    steps: int = 0
    gps_hidden: int = 0  # steps the occlusion model took the GPS reading away
    by_fix: dict[str, int] | None = None  # steps per State pose_fix (gps, odometry, lost)
    error_sum: float = 0.0
    error_max: float = 0.0
    std_max: float = 0.0

    def add(self, report: BrainReport, truth_x: float, truth_y: float) -> None:
        self.steps += 1
        if self.by_fix is None:
            self.by_fix = {}
        self.by_fix[report.pose] = self.by_fix.get(report.pose, 0) + 1
        if report.pose != "lost":
            err = math.hypot(report.pose_x - truth_x, report.pose_y - truth_y)
            self.error_sum += err
            self.error_max = max(self.error_max, err)
            self.std_max = max(self.std_max, report.pose_std)

    def as_dict(self) -> dict[str, object]:
        posed = self.steps - (self.by_fix or {}).get("lost", 0)
        return {
            "steps": self.steps,
            "gps_hidden_steps": self.gps_hidden,
            "by_fix": dict(self.by_fix or {}),
            "error_mean_m": round(self.error_sum / posed, 4) if posed else None,
            "error_max_m": round(self.error_max, 4),
            "std_max_m": round(self.std_max, 4),
        }


class RobotHardware:
    """One simulated robot's GPS, encoders, motors and competition switch."""

    def __init__(
        self,
        world: World,
        index: int,
        rng: np.random.Generator | None,
        ring_counter: bool = True,
        clamp_sensor: bool = True,
        imu: bool = True,
        imu_drift_deg_s: float = 0.0,
        gps_occlusion: sensors.GpsOcclusion | None = None,
    ) -> None:
        if not 0 <= index < len(world.robots):
            raise ValueError(f"robot {index} is not in this world ({len(world.robots)} robots)")
        self.world = world
        self.index = index
        self.rng = rng  # None: a noiseless GPS
        self.gps_failure: str | None = None  # set to make the GPS fail this way
        self.ring_counter = ring_counter
        self.clamp_sensor = clamp_sensor
        self.imu = imu
        if not (math.isfinite(imu_drift_deg_s) and abs(imu_drift_deg_s) < 10.0):
            raise ValueError(f"imu_drift_deg_s must be small and finite, got {imu_drift_deg_s}")
        self.imu_drift_deg_s = imu_drift_deg_s
        self.gps_occlusion = gps_occlusion
        self.gps_hidden_steps = 0  # readings the occlusion model took away
        self.pose_track = PoseTrack()
        self._imu_deg = 0.0
        self._imu_heading: float | None = None
        self._imu_time: float | None = None
        self._sent_phase: str | None = None
        self._sent_rings: int | None = None
        self._sent_goal: bool | None = None
        self.last_command = DriveCommand(0.0, 0.0, intake=False)
        self._brain_closed = False  # the Brain's clamp piston at the last report
        self._released = False  # the Brain opened its clamp and has not closed it since

    def forget_sent(self) -> None:
        """A new Brain (rebooted) knows nothing yet: send the phase, ring count and clamp again."""
        self._sent_phase = self._sent_rings = self._sent_goal = None
        self._brain_closed = self._released = False

    @property
    def robot(self) -> RobotState:
        return self.world.robots[self.index]

    def _imu_reading(self) -> float | None:
        """The robot's cumulative clockwise rotation since the first reading, plus drift."""
        if not self.imu:
            return None
        r = self.robot
        t = float(self.world.time_s)
        if self._imu_heading is not None and self._imu_time is not None:
            self._imu_deg += (r.heading - self._imu_heading + 180.0) % 360.0 - 180.0
            self._imu_deg += self.imu_drift_deg_s * (t - self._imu_time)
        self._imu_heading, self._imu_time = r.heading, t
        return self._imu_deg

    def read(self, phase: str) -> SensorReading:
        gps = None
        failure = self.gps_failure
        if failure is None:
            g = sensors.gps_with_occlusion(self.world, self.index, self.rng, self.gps_occlusion)
            if g is None:
                failure = "error"  # the strip is hidden: the sensor has no fix
                self.gps_hidden_steps += 1
            else:
                gps = (g.x, g.y, g.heading_deg, g.error_m)
        left, right = self.robot.wheel_speeds()
        rings = min(self.robot.held, 254) if self.ring_counter else None
        goal = (self.robot.carried_goal is not None) if self.clamp_sensor else None
        return SensorReading(
            gps, failure, left, right, phase, rings, goal, imu_deg=self._imu_reading()
        )

    def sensor_lines(self, reading: SensorReading) -> list[str]:
        """Side-channel commands that put this reading into brain_host (the phase, the ring count
        and the clamp sensor only when they change: brain_host keeps them, and a line costs a
        parse)."""
        lines = []
        if reading.phase != self._sent_phase:
            lines.append(BrainHost.phase_line(reading.phase))
            self._sent_phase = reading.phase
        if reading.rings is not None and reading.rings != self._sent_rings:
            lines.append(BrainHost.rings_line(reading.rings))
            self._sent_rings = reading.rings
        if reading.goal_at_back is not None and reading.goal_at_back != self._sent_goal:
            lines.append(BrainHost.clamp_line(reading.goal_at_back))
            self._sent_goal = reading.goal_at_back
        if reading.gps is not None:
            lines.append(BrainHost.gps_line(*reading.gps))
        else:
            lines.append(BrainHost.gps_failure_line(reading.gps_failure or "absent"))
        lines.append(BrainHost.imu_line(reading.imu_deg))
        lines.append(BrainHost.measured_line(reading.left_mps, reading.right_mps))
        return lines

    def _clamp(self, report: BrainReport) -> bool | None:
        """The World's clamp from the Brain's piston: None (the World's auto clamp) until the
        Brain opens it, then False (release, grab nothing) until the Brain closes it again."""
        if self._brain_closed and not report.clamp_closed:
            self._released = True
        elif report.clamp_closed:
            self._released = False
        self._brain_closed = report.clamp_closed
        return False if self._released else None

    def command(self, report: BrainReport) -> DriveCommand:
        """The Brain's motor outputs as the simulator's command for this robot. Stopped motors
        (brake) are zero speed; the intake runs only when the Brain runs it."""
        clamp = self._clamp(report)
        if report.link != "off":  # a rebooting Brain reports nothing
            self.pose_track.gps_hidden = self.gps_hidden_steps
            self.pose_track.add(report, self.robot.x, self.robot.y)
        if report.stopped:
            cmd = DriveCommand(0.0, 0.0, intake=report.intake, clamp=clamp)
        else:
            rc = self.robot.config
            cmd = DriveCommand.from_wheels(rc, report.left_mps, report.right_mps, report.intake)
            cmd.clamp = clamp
        self.last_command = cmd
        return cmd
