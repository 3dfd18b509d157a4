"""Compiled loops (numba) for the batched backend's hottest question: which rings each camera
sees.

sim.visibility answers it for the twin in numpy: the frustum (sim.visibility.frustum) and the
prism occlusion (boxes_blocked, discs_blocked). For thousands of robots at once, numpy's
temporaries cost fourteen times what a loop over matches in parallel does (measured:
docs/notes/2026-11-28-fast-backend.md), so `visible_rings` is that same arithmetic, step for step,
compiled. tests/sim/fast/test_observe.py holds it to the twin's answer, ring for ring.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

_T_MAX = 1.0 - 1e-6  # sim.visibility.occluded's: the segment stops short of its target
_EPS = 1e-9  # sim.visibility._EPS: a sight line parallel to a slab


@nb.njit(cache=True, inline="always")
def _through(lo: float, hi: float, z0: float, dz: float, height: float) -> bool:
    """sim.visibility._blocked for one segment and one prism: inside it on (lo, hi) and below
    its top somewhere there."""
    lo = max(lo, 0.0)
    hi = min(hi, _T_MAX)
    if not hi > lo:
        return False
    return min(z0 + lo * dz, z0 + hi * dz) < height


@nb.njit(cache=True, inline="always")
def _slab(a: float, da: float, h: float) -> tuple[float, float]:
    """sim.visibility._slab_interval for one axis."""
    if abs(da) < _EPS:
        if abs(a) <= h:
            return -math.inf, math.inf
        return math.inf, -math.inf
    ta = (-h - a) / da
    tb = (h - a) / da
    return min(ta, tb), max(ta, tb)


@nb.njit(cache=True, parallel=True)
def visible_rings(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    heading: NDArray[np.float64],
    turn: NDArray[np.float64],
    ring_xy: NDArray[np.float64],
    floor: NDArray[np.bool_],
    ring_z: float,
    cam: NDArray[np.float64],
    box: NDArray[np.float64],
    gx: NDArray[np.float64],
    gy: NDArray[np.float64],
    disc: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """(B, R, N): the floor rings each robot's camera sees.

    x, y, heading (degrees), turn (rad/s): the robots (B, R). ring_xy (B, N, 2), floor (B, N).
    cam (R, 14): forward_m, right_m, height_m, cos and sin of tilt, fx, fy, cx, cy, width,
    height, near_m, max_range_m, max_turn_rate_rad_s (inf: none). box (R, 3): each robot as a
    prism to the others: half width, half length, height. gx, gy (B, G): the goals; disc
    (2G, 2): radius and height of each goal's base, then of each post."""
    n_match, n_robot = x.shape
    n_ring = ring_xy.shape[1]
    n_goal = gx.shape[1]
    out = np.zeros((n_match, n_robot, n_ring), dtype=np.bool_)
    for b in nb.prange(n_match):
        for i in range(n_robot):
            c = cam[i]
            if abs(turn[b, i]) > c[13]:
                continue
            h = math.radians(heading[b, i])
            s, co = math.sin(h), math.cos(h)
            # Camera position: ahead along (s, co), right along (co, -s) (sim.visibility).
            px = x[b, i] + c[0] * s + c[1] * co
            py = y[b, i] + c[0] * co - c[1] * s
            pz = c[2]
            ct, st = c[3], c[4]
            for n in range(n_ring):
                if not floor[b, n]:
                    continue
                dx = ring_xy[b, n, 0] - px
                dy = ring_xy[b, n, 1] - py
                dz = ring_z - pz
                # Field -> robot (x right, y forward, z up) -> optical (x, -z, y) -> tilt.
                rx = co * dx - s * dy
                ry = s * dx + co * dy
                ox = rx
                oy = ct * -dz + st * ry
                oz = -st * -dz + ct * ry
                if not oz > c[11]:
                    continue
                if math.sqrt(ox * ox + oy * oy + oz * oz) > c[12]:
                    continue
                u = c[5] * ox / oz + c[7]
                v = c[6] * oy / oz + c[8]
                if not (u >= 0 and u < c[9] and v >= 0 and v < c[10]):
                    continue
                hidden = False
                for k in range(n_robot):
                    if k == i:
                        continue
                    hk = math.radians(heading[b, k])
                    sk, ck = math.sin(hk), math.cos(hk)
                    relx, rely = px - x[b, k], py - y[b, k]
                    lo_x, hi_x = _slab(relx * ck - rely * sk, dx * ck - dy * sk, box[k, 0])
                    lo_y, hi_y = _slab(relx * sk + rely * ck, dx * sk + dy * ck, box[k, 1])
                    if _through(max(lo_x, lo_y), min(hi_x, hi_y), pz, dz, box[k, 2]):
                        hidden = True
                        break
                if not hidden:
                    qa = dx * dx + dy * dy
                    for m in range(2 * n_goal):
                        g = m % n_goal
                        relx, rely = px - gx[b, g], py - gy[b, g]
                        qb = 2.0 * (dx * relx + dy * rely)
                        qc = relx * relx + rely * rely - disc[m, 0] ** 2
                        d = qb * qb - 4 * qa * qc
                        if not (d >= 0 and qa > _EPS):
                            continue
                        root = math.sqrt(d)
                        t0 = (-qb - root) / (2 * qa)
                        t1 = (-qb + root) / (2 * qa)
                        if _through(t0, t1, pz, dz, disc[m, 1]):
                            hidden = True
                            break
                out[b, i, n] = not hidden
    return out


@nb.njit(cache=True, parallel=True)
def nearest_seen(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    heading: NDArray[np.float64],
    ring_xy: NDArray[np.float64],
    seen: NDArray[np.bool_],
    slots: int,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Each robot's nearest `slots` seen rings in its frame (x right, y forward), nearest first
    with equal distances in ring order (build_frame's stable sort): (B, R, slots, 2) and how
    many slots are filled (B, R)."""
    n_match, n_robot = x.shape
    n_ring = ring_xy.shape[1]
    out = np.zeros((n_match, n_robot, slots, 2))
    count = np.zeros((n_match, n_robot), dtype=np.int64)
    for b in nb.prange(n_match):
        d2 = np.empty(slots)
        for i in range(n_robot):
            h = math.radians(heading[b, i])
            s, co = math.sin(h), math.cos(h)
            k = 0
            for n in range(n_ring):
                if not seen[b, i, n]:
                    continue
                px = ring_xy[b, n, 0] - x[b, i]
                py = ring_xy[b, n, 1] - y[b, i]
                lx = px * co - py * s
                ly = px * s + py * co
                dist = lx * lx + ly * ly
                if k == slots and not dist < d2[k - 1]:
                    continue
                # Insert after every slot not farther (equal distances keep ring order).
                j = min(k, slots - 1)
                while j > 0 and dist < d2[j - 1]:
                    if j < slots:
                        d2[j] = d2[j - 1]
                        out[b, i, j, 0] = out[b, i, j - 1, 0]
                        out[b, i, j, 1] = out[b, i, j - 1, 1]
                    j -= 1
                d2[j] = dist
                out[b, i, j, 0] = lx
                out[b, i, j, 1] = ly
                k = min(k + 1, slots)
            count[b, i] = k
    return out, count
