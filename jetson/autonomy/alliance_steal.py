"""The steal and the tow: the 24"'s phases that take neutral goals home and climb with a goal
another robot holds too (AllianceConfig.steal_s, steal_climb, steal_again_m, the tow's settings).

A mixin of jetson/autonomy/alliance.py's AllianceStrategy, kept apart so that the strategy's
main module holds the plan, the goals and the climb, and this one the steal: `_phase_steal`
(leave the goal it holds home, choose the neutral goal to take: `_steal_goal`), `_phase_haul`
(drag it home; test whether another robot holds it too), `_phase_haul_climb` and `_tow` (tow a
goal another robot holds to the stage and up the board). Its methods read and set the
strategy's state (the goal beliefs, the carried-goal tracker, the phase) and call its driving
helpers (`_drive_to`, `_turn_to`, `_arrive`, `_get_goal`, `_on_board`, `_phase_climb`).
"""

from __future__ import annotations

import math

import numpy as np

from jetson.autonomy.alliance_config import AllianceConfig, AllianceInputs, RobotRole
from jetson.autonomy.alliance_state import GoalBelief, Move, Pose, Vec
from jetson.autonomy.carried_goal import CarriedGoalTracker
from jetson.autonomy.field_layout import FieldLayout, GoalLayout
from jetson.autonomy.geometry import angle_diff_deg, heading_of

# Where the steal looks when it knows of no neutral goal to take (alliance frame, m), 4 s each:
# its own home zone's two sides and middle (the ring race's chaser parks its loaded goal there),
# then the field's middle.
_STEAL_SEARCH: tuple[tuple[float, float], ...] = (
    (-0.9, -1.0),
    (-1.0, -0.9),
    (-0.9, 0.0),
    (-0.9, 1.0),
    (-1.0, 0.9),
    (-0.9, 0.0),
    (0.0, -0.8),
    (0.25, -1.35),
    (0.3, 0.0),
    (0.0, 0.8),
    (0.25, 1.35),
    (0.3, 0.0),
)


class StealPhases:
    """The steal's phases of AllianceStrategy (see the module docstring). Its own state it sets
    up in _reset_steal (called by AllianceStrategy.reset); the strategy's state it reads and
    sets too (AllianceStrategy.reset):"""

    config: AllianceConfig
    role: RobotRole
    layout: FieldLayout
    goals: dict[str, GoalBelief]  # the goal beliefs, by name
    holding: str | None  # the goal in the clamp
    target_goal: str | None
    intent: str
    phase_since: float
    _now: float
    _widest: GoalLayout  # the widest goal base (clamp points)
    _tracker: CarriedGoalTracker  # the neutral goal another robot carries
    _moves: list[Move]  # the last tug_window_s of commands
    _chased: dict[str, float]  # name -> chased too long: not stolen until
    _deposited: list[str]  # goals left in the home zone, oldest first
    _contested: bool  # the goal hauled is another robot's too: held to the end
    _dragged_checked: bool  # a whole drag window was read since the clamp closed
    _test_to: Vec | None  # where the steal tests the goal it clamped
    _clamped_at: float
    _stage_goal: str | None
    _bad_stages: list[Vec]
    _backoff_until: float
    _lined: bool  # climbing with a held goal: in its lane, heading for the wall
    _towing: bool  # towing a held goal to its stage (else lining up there)

    def _reset_steal(self) -> None:
        """The steal's own state, as a match starts."""
        self._steal_dropped = False  # the goal held when the steal began is dealt with
        self._steal_carried = False  # the goal it backs onto was seen carried
        self._hauled = False  # the goal hauled reached the haul spot
        self._left_at: list[Vec] = []  # where the steal left goals it tested free (clamp point)
        self._tow_out = False  # towing out to the lane beyond the stage first (_tow)
        self._pull_until = -1.0  # climbing with a held goal: at full pull until

    def _phase_steal(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The 24" (AllianceConfig.steal_s): leave the goal it holds in the home zone, then
        back onto the neutral goal to steal (_steal_goal) and haul it home."""
        if (
            inputs.goal_clamped
            and not self._steal_dropped
            and (self._contested or not self._steal_worth(pose))
        ):
            # No other robot's goal to take: its own goal is the one to keep home.
            self._steal_dropped = True
            self._steal_carried = True  # held to the end: a goal let go may be taken
            self._set_phase("haul", pose.t)
            self._contested = True
            self._hauled = False
            return self._phase_haul(pose, inputs, dt)
        if inputs.goal_clamped and not self._steal_dropped:
            spot = self._haul_spot(pose)
            if self.layout.in_home_zone(tuple(self._clamp_point(pose, self._widest))):
                spot = pose.xy  # its goal is home already: leave it here
            near = float(np.hypot(*(spot - pose.xy))) < 0.25
            if not near and pose.t - self.phase_since < 8.0:
                self.intent = "steal_drop"
                return (*self._drive_to(pose, spot, None, speed=0.8), True)
            if self.holding is not None:
                self._deposited.append(self.holding)
            self._steal_dropped = True
            self.phase_since = pose.t
            self.intent = "steal_drop"
            return 0.0, 0.0, False
        if not self._steal_dropped:
            self._steal_dropped = True  # nothing held when the steal began
        if pose.t - self.phase_since < 0.6:
            # The phase's first 0.6 s: away from a goal just left (and at the steal's start).
            return 0.4 * self.role.max_linear_mps, 0.0, False
        if inputs.goal_clamped:
            self._set_phase("haul", pose.t)
            # A goal seen carried is another robot's: held to the end (the robot holding it
            # may stand still, and then nothing pulls back to tell); so is one standing where
            # the steal left a goal it tested free (AllianceConfig.steal_again_m).
            self._contested = self._contested or self._steal_carried or self._taken_again(pose)
            self._hauled = False
            return self._phase_haul(pose, inputs, dt)
        name = self._steal_goal(pose)
        if name is None:
            # None known: sweep the home zone, then the field's middle (the camera sees goals
            # up to about 2 m), and a neutral goal not found where it was tried may be found
            # again.
            self.intent = "steal_search"
            self._stage_goal = None  # a goal found again is chased afresh (goal_chase_s)
            for b in self.goals.values():
                if b.goal.owner is None:
                    b.tries = 0.0
            look = np.array(_STEAL_SEARCH[int(pose.t // 4.0) % len(_STEAL_SEARCH)])
            if float(np.hypot(*(look - pose.xy))) > 0.2:
                return (*self._drive_to(pose, look, None, speed=0.7), False)
            return 0.0, 0.5 * self.role.max_angular_rad_s, False
        if self.target_goal != name:
            self._bad_stages = []
        self.target_goal = name
        xy = self.goals[name].xy
        # One seen carried is held to the end; any other is tested once clamped (_phase_haul:
        # another robot's comes slower than the robot drives).
        self._steal_carried = self._seen_moving(xy)
        self.intent = f"steal:{name}"
        return self._get_goal(name, pose, inputs, dt, wait_until=None)

    def _taken_again(self, pose: Pose) -> bool:
        """The goal just clamped stands where the steal left one it tested free
        (AllianceConfig.steal_again_m)."""
        near = self.config.steal_again_m
        if near is None:
            return False
        at = self._clamp_point(pose, self._widest)
        return any(float(np.hypot(*(at - p))) < near for p in self._left_at)

    def _haul_spot(self, pose: Pose) -> Vec:
        """Where the 24" leaves or holds a goal it takes home: deep in the home zone beside the
        platform, on the side of the platform it is on (the goal trails it toward the field)."""
        c = self.config
        plat = self.layout.platform
        side = 1.0 if float(pose.xy[1]) > plat.center[1] else -1.0
        return np.array([plat.x_at(c.steal_haul_along_m), plat.center[1] + side * c.steal_haul_y_m])

    def _steal_goal(self, pose: Pose) -> str | None:
        """The neutral goal to steal: the one another robot carries (the other alliance's
        loaded goal, wherever it stands; jetson/autonomy/carried_goal.py) first, then one
        standing in the home zone, then the nearest; never one on a platform, one by the other
        alliance's platform, or one it left itself (but `refetch_s` before the end, when it is
        the one to climb with)."""
        line = self.layout.home_zone[2]
        plat = self.layout.platform
        tr = self._tracker.carried(self._now)
        if tr is not None:
            # The goal followed is the neutral one believed nearest it (or a missing one).
            names = [
                n
                for n, b in self.goals.items()
                if b.goal.owner is None and n != self.holding and n not in self._deposited
            ]
            if names and not any(self._seen_moving(self.goals[n].xy) for n in names):

                def away(n: str) -> float:
                    xy = self.goals[n].xy
                    return math.inf if xy is None else float(np.hypot(*(xy - tr.xy)))

                self.goals[min(names, key=away)].xy = tr.xy.copy()
        late = self._time_left(pose) <= self.config.refetch_s  # one to climb with, then
        best, best_cost = None, math.inf
        for name, b in self.goals.items():
            if b.goal.owner is not None or b.xy is None or (name in self._deposited and not late):
                continue
            if self._chased.get(name, -math.inf) > self._now:
                continue  # chased goal_chase_s without taking it: another one for a while
            x, y = float(b.xy[0]), float(b.xy[1])
            r = b.goal.base_radius_m
            if plat.either_contains((x, y), r, r + 0.15):
                continue  # on a platform; or by the other's, protected in the endgame
            carried = self._seen_moving(b.xy)
            cost = float(np.hypot(*(b.xy - pose.xy))) - (3.0 if carried else 0.0)
            if x < line - r and not carried:
                # Standing in the home zone, and not left there by this robot: most likely the
                # other alliance's loaded goal, parked by its carrier (tested on the way home).
                cost -= 3.0
            if cost < best_cost:
                best, best_cost = name, cost
        return best

    def _steal_worth(self, pose: Pose) -> bool:
        """A neutral goal another robot carries is followed, away from the clamp: the goal it
        holds is worth leaving for it."""
        tr = self._tracker.carried(self._now)
        if tr is None:
            return False
        clamp = self._clamp_point(pose, self._widest)
        return float(np.hypot(*(tr.xy - clamp))) > 0.5

    def _seen_moving(self, xy: Vec | None) -> bool:
        """The neutral goal carried by another robot was last seen near `xy`."""
        tr = self._tracker.carried(self._now)
        if xy is None or tr is None:
            return False
        return float(np.hypot(*(tr.xy - xy))) < 0.3

    def _phase_haul(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """Drag the stolen goal into the home zone, beside the platform. One not seen carried is
        tested first (driven ahead until a whole drag window was read). A goal another robot
        still holds (it comes slower than the robot drives: a tug of war, which the stronger
        pull wins) is held there to the end, pulling toward the wall (with `steal_climb`, it is
        climbed with: _phase_haul_climb); a free one is left there and the next is stolen, but
        from `refetch_s` before the end it is kept to climb with."""
        if not inputs.goal_clamped:
            self._set_phase("steal", pose.t)
            return 0.0, 0.0, False
        if self._contested and self.config.steal_climb:
            # Held by another robot too, and climbed with: to the stage in its lane and up.
            self._set_phase("haul_climb", pose.t)
            return self._phase_haul_climb(pose, inputs, dt)
        plat = self.layout.platform
        spot = self._haul_spot(pose)
        # The test: with the goal just clamped, driving ahead until a whole drag window was read
        # (_check_dragging), toward the haul spot when it is far, else out toward the field
        # (at a wall the goal would come slower whoever holds it).
        testing = (
            not self._contested
            and not self._dragged_checked
            and pose.t - self._clamped_at < self.config.steal_test_s
        )
        if testing and self._test_to is None:
            far = float(np.hypot(*(spot - pose.xy))) > 0.8
            self._test_to = spot if far else np.array([pose.xy[0] + 1.0, 0.5 * pose.xy[1]])
        if not self._hauled and (testing or float(np.hypot(*(spot - pose.xy))) > 0.15):
            self.intent = "haul"
            if testing and self._test_to is not None:
                spot = self._test_to
            if self._contested:
                # Another robot holds it too: pull at full speed all the way (a tug goes to
                # the stronger pull; slowing down or turning in place hands it the goal),
                # steering toward the spot.
                d = spot - pose.xy
                face = float(heading_of(d))
                w = float(np.clip(self._turn_to(pose, face), -1.5, 1.5))
                return self.role.max_linear_mps, w, True
            v, w = self._drive_to(pose, spot, None, speed=1.0)
            self._backoff_until = -1.0  # never back off: that would hand the goal back
            if testing:
                v = max(v, 0.6 * self.role.max_linear_mps)  # fast enough to tell (_check_dragging)
            return max(v, 0.0), w, True
        if not self._contested and self._time_left(pose) <= self.config.refetch_s:
            # A free goal late in the match: kept, and taken to the stage to climb with.
            if self.config.steal_climb:
                self._set_phase("haul_climb", pose.t)
                return self._phase_haul_climb(pose, inputs, dt)
            self._hauled = True
            self.intent = "keep"
            return 0.0, 0.0, True
        if not self._contested:
            # A free goal: leave it here (20 points, its rings count here) and take the next.
            if self.holding is not None:
                self._deposited.append(self.holding)
            self._left_at.append(self._clamp_point(pose, self._widest))
            self._hauled = False
            self._set_phase("steal", pose.t)
            self.intent = "steal_drop"
            return 0.0, 0.0, False
        self._hauled = True
        self.intent = "hold"
        return self.role.max_linear_mps, self._turn_to(pose, plat.wall_heading_deg), True

    def _phase_haul_climb(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The 24" (AllianceConfig.steal_climb) with a goal another robot holds too: towed to the
        stage in its lane (_tow), lined up there facing the wall, and held there (towed back
        when dragged away) until `climb_after_s` before the end; then straight at the wall at
        the board's speed, up the board once the sentry tips it down, and against the wall to
        the end, at full speed in the last `tow_press_s`. Dragged backward while climbing (the
        other robot pulls harder: a tug of war goes to the stronger pull), it pulls straight
        ahead at full speed for `tug_s`. From `tow_into_board_s` before the end a goal another
        robot holds too is towed straight into the board instead (no lining up, no wait)."""
        c = self.config
        left = self._time_left(pose)
        if not inputs.goal_clamped:
            if left > c.climb_24_s:
                self._set_phase("steal", pose.t)  # it let go: steal on
                return 0.0, 0.0, False
            self._set_phase("climb", pose.t)
            return self._phase_climb(pose, inputs, dt)
        y = c.board_y_24_m
        last = left < c.tow_press_s
        if self._contested and c.tow_into_board_s is not None and left <= c.tow_into_board_s:
            # The climb's last stretch (tow_into_board_s): never slower than tow_speed (below
            # it the other robot's pull wins and drags the chain away: lining up at the stage
            # and waiting there lost the goal). Along the lane into the board's edge, pressed
            # there until the sentry tips the board down, then up it and against the wall.
            self.intent = "tow_press"
            return (*self._tow(pose, y, least=1.0 if last else c.tow_speed, into=True), True)
        wall = self.layout.platform.wall_heading_deg
        waiting = left > c.climb_after_s
        stage = np.array([self._board_x(c.stage_along_m), y])
        far = float(np.hypot(*(stage - pose.xy)))
        if far > c.tow_near_m + 0.2 and (waiting or not self._lined):
            self._towing, self._lined = True, False  # dragged away from the stage: back to it
        elif far < c.tow_near_m:
            self._towing = False
        if self._towing or (last and not self._lined):
            # In the last seconds the other robot heads home: tow at full speed, never line up.
            self.intent = "tow"
            return (*self._tow(pose, y, least=1.0 if last else c.tow_speed), True)
        if not self._lined:
            if not (far < 0.1 and abs(angle_diff_deg(wall, pose.heading)) < 8.0):
                self.intent = "haul_stage"
                return (*self._arrive(pose, stage, wall), True)
            self._lined = True
        if waiting:
            # Not yet: wait at the stage facing the wall, off the board's edge (pressed against
            # it while the board is level, the robot and its chain slide along it). Only ever
            # forward: backing up hands the goal to the other robot's pull.
            self.intent = "haul_wait"
            self._moves.clear()
            v, w = self._on_board(pose, y, c.stage_along_m)
            return max(v, 0.0), w, True
        if self._dragged_back(pose):
            self._pull_until = pose.t + c.tug_s
            self._moves.clear()
        if pose.t < self._pull_until:
            # Dragged backward by the other robot: pull straight ahead at full speed.
            self.intent = "pull"
            return self.role.max_linear_mps, 0.0, True
        # Straight at the wall at the board's speed, in its lane: a point past the wall is never
        # reached. On the board in the last `tow_press_s`, at full speed: the other robot heads
        # home then, and its pull never wins against this one's.
        self.intent = "haul_climb"
        plat = self.layout.platform
        along = plat.along(float(pose.xy[0]))
        press = last and along < plat.size[0] / 2
        speed = self.role.max_linear_mps if press else None
        v, w = self._on_board(pose, y, -math.inf, speed=speed)
        if self._against_wall(along):
            w = 0.0  # against the wall: turning there walks the robot sideways along it
        return v, w, True

    def _tow(self, pose: Pose, y: float, least: float, into: bool = False) -> tuple[float, float]:
        """Drag a goal another robot holds too into the lane at `y`: ahead at `least` of the
        top speed or more whatever the heading (turning in place, or slowing down, hands the goal
        to the other robot's pull), steering at the lane; beside the platform (short of the
        stage and out of the lane) out to the lane beyond the stage first. `into`: on along the
        lane past the stage, into the board and up it (small turns only once at the board)."""
        c = self.config
        plat = self.layout.platform
        along = plat.along(float(pose.xy[0]))
        off = abs(float(pose.xy[1]) - y)
        approach = c.stage_along_m + c.tow_approach_m
        out = np.array([plat.x_at(approach), y])
        if along < c.stage_along_m and off > 2 * c.tow_lane_m:
            self._tow_out = True
        if self._tow_out and float(np.hypot(*(out - pose.xy))) < c.tow_near_m:
            self._tow_out = False
        if self._tow_out:
            target = out
        else:
            floor = -math.inf if into else c.stage_along_m
            target = np.array([plat.x_at(max(along - c.tow_lookahead_m, floor)), y])
        d = target - pose.xy
        err = math.radians(angle_diff_deg(float(heading_of(d)), pose.heading))
        if into and along < plat.size[0] / 2 + self.role.length_m / 2:
            # At or on the board: small corrections only.
            err = float(np.clip(err, -c.tow_board_err_rad, c.tow_board_err_rad))
            if self._against_wall(along):
                err = 0.0  # against the wall: turning there walks the robot sideways along it
        v = self.role.max_linear_mps * max(least, math.cos(err))
        w = float(
            np.clip(c.turn_gain * err, -self.role.max_angular_rad_s, self.role.max_angular_rad_s)
        )
        return v, w
