"""What the whole game's mechanisms do, for a batch of matches (sim.world.batch): a tug of war over
a goal two robots clamp, and where a robot's mechanism puts a ring on the goal it holds. World
calls these as a batch of one; the batched backend (sim.fast) on all its matches at once.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

from sim.world.batch import GameConsts

LOW, HIGH, BASE = 0, 1, 2  # where a ring goes on a goal (ring_slot)


@nb.njit(cache=True)
def _pull(c: GameConsts, i: int, v: float) -> float:
    """Robot i's pull on the goal it holds, N: its drive's force times how hard it drives away
    from the goal (v, its commanded speed, against its clamp's side)."""
    away = -c.clamp_sign[i] * v
    return c.pull[i] * max(0.0, away) / c.max_v[i]


@nb.njit(cache=True)
def tug_of_war(
    c: GameConsts,
    carrier: NDArray[np.int64],
    contester: NDArray[np.int64],
    v: NDArray[np.float64],
    w: NDArray[np.float64],
    live: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """A goal clamped by robots of both alliances (carrier and contester, (B, G)), each pulling
    with its drive's force times how hard it drives away from the goal: the stronger pull moves,
    slowed by the weaker, and drags the other robot with the goal. The three hold together as
    one rigid body: the dragged robot neither drives nor turns by itself. Equal pulls hold both
    still; when neither pulls, the one that turns harder (w) turns the three. The winner becomes
    the goal's carrier (in place). Returns each robot's share of its commanded speed (B, R; NaN:
    in no tug of war) and whether it is dragged (B, R: it neither drives nor turns)."""
    n, r = v.shape
    share = np.full((n, r), np.nan)
    dragged = np.zeros((n, r), dtype=np.bool_)
    for b in range(n):
        if not live[b]:
            continue
        for g in range(carrier.shape[1]):
            a, o = carrier[b, g], contester[b, g]
            if a < 0 or o < 0:
                continue
            pa, po = _pull(c, a, v[b, a]), _pull(c, o, v[b, o])
            if pa == po:
                share[b, a] = share[b, o] = 0.0
                if pa > 0.0:  # both pull: held still, turning included
                    dragged[b, a] = dragged[b, o] = True
                    continue
                # Neither pulls: the one that turns harder swings the goal and the other robot.
                if abs(w[b, o]) > abs(w[b, a]):
                    carrier[b, g], contester[b, g] = o, a
                    a, o = o, a
                dragged[b, o] = True
                continue
            if pa > po:
                win, lose, pw, pl = a, o, pa, po
            else:
                win, lose, pw, pl = o, a, po, pa
            share[b, win] = (pw - pl) / (pw + pl)
            share[b, lose] = 0.0
            dragged[b, lose] = True
            if win == o:  # the goal now goes where the winner drags it
                carrier[b, g], contester[b, g] = o, a
    return share, dragged


@nb.njit(cache=True)
def ring_slot(
    loads_base: bool, reaches_high: bool, high: int, low: int, high_cap: int, branch_cap: int
) -> int:
    """Where a robot's mechanism puts a ring on the goal it holds (high and low: the rings on its
    high branch and low branches now): the high branch when its lift reaches one with room, else
    the low branches while they have room, else (or with an intake that only drops rings into
    the base) the base. LOW, HIGH or BASE."""
    if loads_base:
        return BASE
    if reaches_high and high < high_cap:
        return HIGH
    if low >= branch_cap:
        return BASE
    return LOW


@nb.njit(cache=True)
def place_rings(
    due: NDArray[np.bool_],
    carried: NDArray[np.int64],
    rings: NDArray[np.int64],
    rings_high: NDArray[np.int64],
    rings_base: NDArray[np.int64],
    loads_base: NDArray[np.bool_],
    reaches_high: NDArray[np.bool_],
    high_cap: NDArray[np.int64],
    branch_cap: NDArray[np.int64],
) -> None:
    """Robots putting one ring each (due, (B, R)) on the goal they hold (carried): where each
    goes (ring_slot), robot by robot in index order, counted in rings (each goal's total),
    rings_high and rings_base (B, G) in place."""
    n, r = due.shape
    for b in range(n):
        for i in range(r):
            if not due[b, i]:
                continue
            g = carried[b, i]
            high, base = rings_high[b, g], rings_base[b, g]
            slot = ring_slot(
                loads_base[i], reaches_high[i], high, rings[b, g] - high - base,
                high_cap[g], branch_cap[g],
            )  # fmt: skip
            if slot == HIGH:
                rings_high[b, g] += 1
            elif slot == BASE:
                rings_base[b, g] += 1
            rings[b, g] += 1
