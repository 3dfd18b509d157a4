"""Compiled loops (numba) for the batched backend's hot spots: which rings each camera sees, and
the physics' substeps.

sim.visibility answers it for the twin in numpy, one camera at a time: the frustum
(in_frustum) and the prism occlusion (occluded). For thousands of robots at once, numpy's
temporaries cost fourteen times what a loop over matches in parallel does (measured:
docs/notes/2026-11-28-fast-backend.md), so `visible_rings` is that same arithmetic, step for step,
compiled. tests/sim/fast/test_observe.py holds it to the twin's answer, ring for ring.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager

import numba as nb
import numpy as np
from numpy.typing import NDArray

# Below this many matches a compiled loop runs on one thread: a parallel region's start costs
# more than the split saves, and on a busy machine it waits for a thread the system has not
# scheduled (docs/notes/2026-11-28-fast-backend.md).
SERIAL_BELOW = 128

_T_MAX = 1.0 - 1e-6  # sim.visibility.occluded's: the segment stops short of its target
_EPS = 1e-9  # sim.visibility._EPS: a sight line parallel to a slab


@contextmanager
def threads_for(n_matches: int) -> Iterator[None]:
    """Run the compiled loops inside on one thread for a batch under SERIAL_BELOW matches, on
    numba's threads otherwise (the caller's setting is restored after)."""
    if n_matches >= SERIAL_BELOW:
        yield
        return
    before = nb.get_num_threads()
    nb.set_num_threads(1)
    try:
        yield
    finally:
        nb.set_num_threads(before)


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


@nb.njit(cache=True, inline="always")
def insert_nearest(d2, xy, ok, filled, dist, x, y, okv):
    """Put the point (x, y), squared distance `dist`, ok value `okv`, into nearest-first slots
    (d2, xy, ok: len(d2) of them, `filled` in use) after every slot not farther, so equal
    distances keep their arrival order (build_frame's stable sort); returns the slots filled."""
    slots = d2.shape[0]
    if slots == 0 or (filled == slots and not dist < d2[filled - 1]):
        return filled
    j = min(filled, slots - 1)
    while j > 0 and dist < d2[j - 1]:
        d2[j] = d2[j - 1]
        xy[j, 0] = xy[j - 1, 0]
        xy[j, 1] = xy[j - 1, 1]
        ok[j] = ok[j - 1]
        j -= 1
    d2[j] = dist
    xy[j, 0] = x
    xy[j, 1] = y
    ok[j] = okv
    return min(filled + 1, slots)


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
        ok = np.empty(slots)
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
                k = insert_nearest(d2, out[b, i], ok, k, lx * lx + ly * ly, lx, ly, 1.0)
            count[b, i] = k
    return out, count


# --- physics ---------------------------------------------------------------------------------
# One match's substeps, as sim.fast.world describes them, compiled and run for every match in
# parallel. Bodies: robots 0..R-1 (boxes), goals R..R+G-1 (discs); a goal in a clamp (carrier
# >= 0) sits at its robot's clamp point and pushes with its own mass at the robot's speed.


@nb.njit(cache=True, inline="always")
def _clamp_point(x: float, y: float, heading: float, back: float) -> tuple[float, float]:
    h = math.radians(heading)
    return x + back * math.sin(h), y + back * math.cos(h)


@nb.njit(cache=True)
def _follow(b, x, y, heading, rvx, rvy, gx, gy, gvx, gvy, carried, offset):
    """Carried goals to their clamp points, moving at their robots' speed."""
    for i in range(x.shape[1]):
        g = carried[b, i]
        if g < 0:
            continue
        gx[b, g], gy[b, g] = _clamp_point(x[b, i], y[b, i], heading[b, i], offset[i, g])
        gvx[b, g] = rvx[b, i]
        gvy[b, g] = rvy[b, i]


@nb.njit(cache=True)
def _slide(
    dx: float, dy: float, free_x: float, free_y: float, friction: float
) -> tuple[float, float]:
    """A push (dx, dy) on a body free to move along x and y (free_x, free_y: 1 or 0): where it
    is held across one axis (a wall), the push along the other less the wall's friction
    (friction x the push taken by the wall), never reversed."""
    if free_x > 0 and free_y > 0:
        return dx, dy
    if free_x > 0:
        return math.copysign(max(0.0, abs(dx) - friction * abs(dy)), dx), 0.0
    if free_y > 0:
        return 0.0, math.copysign(max(0.0, abs(dy) - friction * abs(dx)), dy)
    return 0.0, 0.0


@nb.njit(cache=True)
def _sat(b, i, j, x, y, heading, half_w, half_l):
    """Robots i, j of match b as boxes: the least overlap over the four separating axes
    (negative: the gap between them), that axis from i to j, which axis it is (0, 1: i's
    forward and right; 2, 3: j's), and both boxes' forward and right unit vectors."""
    hi_, hj = math.radians(heading[b, i]), math.radians(heading[b, j])
    fi = (math.sin(hi_), math.cos(hi_))
    ri = (fi[1], -fi[0])
    fj = (math.sin(hj), math.cos(hj))
    rj = (fj[1], -fj[0])
    dx, dy = x[b, j] - x[b, i], y[b, j] - y[b, i]
    axes = (fi, ri, fj, rj)
    best, least, sep_best = 0, math.inf, 0.0
    for a in range(4):
        ax, ay = axes[a]
        reach = (
            half_l[i] * abs(ax * fi[0] + ay * fi[1])
            + half_w[i] * abs(ax * ri[0] + ay * ri[1])
            + half_l[j] * abs(ax * fj[0] + ay * fj[1])
            + half_w[j] * abs(ax * rj[0] + ay * rj[1])
        )
        sep = ax * dx + ay * dy
        over = reach - abs(sep)
        if over < least:
            best, least, sep_best = a, over, sep
    sign = 1.0 if sep_best >= 0 else -1.0
    return least, axes[best][0] * sign, axes[best][1] * sign, best, fi, ri, fj, rj


@nb.njit(cache=True, parallel=True)
def pair_overlaps(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    heading: NDArray[np.float64],
    half_w: NDArray[np.float64],
    half_l: NDArray[np.float64],
    pairs: NDArray[np.int64],
) -> NDArray[np.float64]:
    """(B, P): each robot pair's least box overlap (negative: the gap between them)."""
    out = np.empty((x.shape[0], pairs.shape[0]))
    for b in nb.prange(x.shape[0]):
        for p in range(pairs.shape[0]):
            out[b, p] = _sat(b, pairs[p, 0], pairs[p, 1], x, y, heading, half_w, half_l)[0]
    return out


@nb.njit(cache=True)
def _box_contact(b, i, j, x, y, heading, half_w, half_l):
    """Robots i, j of match b: least overlap, its axis from i to j, and the contact point
    (the incident face clipped to the reference face, Box2D's way)."""
    least, nx, ny, best, fi, ri, fj, rj = _sat(b, i, j, x, y, heading, half_w, half_l)
    on_i = best < 2
    if on_i:
        rc, ic, n_ref, rf, inf_, inr, k_ref, k_inc = (
            (x[b, i], y[b, i]),
            (x[b, j], y[b, j]),
            (nx, ny),
            fi,
            fj,
            rj,
            i,
            j,
        )
    else:
        rc, ic, n_ref, rf, inf_, inr, k_ref, k_inc = (
            (x[b, j], y[b, j]),
            (x[b, i], y[b, i]),
            (-nx, -ny),
            fj,
            fi,
            ri,
            j,
            i,
        )
    along_ref = abs(rf[0] * n_ref[0] + rf[1] * n_ref[1]) > 0.5
    h_n = half_l[k_ref] if along_ref else half_w[k_ref]
    h_t = half_w[k_ref] if along_ref else half_l[k_ref]
    tx, ty = -n_ref[1], n_ref[0]
    a_ = inf_[0] * n_ref[0] + inf_[1] * n_ref[1]
    b_ = inr[0] * n_ref[0] + inr[1] * n_ref[1]
    use_f = abs(a_) >= abs(b_)
    axis = inf_ if use_f else inr
    other = inr if use_f else inf_
    h_axis = half_l[k_inc] if use_f else half_w[k_inc]
    h_other = half_w[k_inc] if use_f else half_l[k_inc]
    sa = a_ if use_f else b_
    sgn = 1.0 if sa > 0 else (-1.0 if sa < 0 else 0.0)
    fx_, fy_ = ic[0] - sgn * h_axis * axis[0], ic[1] - sgn * h_axis * axis[1]
    e0x, e0y = fx_ + h_other * other[0], fy_ + h_other * other[1]
    e1x, e1y = fx_ - h_other * other[0], fy_ - h_other * other[1]
    s0 = (e0x - rc[0]) * tx + (e0y - rc[1]) * ty
    s1 = (e1x - rc[0]) * tx + (e1y - rc[1]) * ty
    ds = s1 - s0
    if abs(ds) < 1e-12:
        lo, hi = 0.0, 1.0
    else:
        t0 = min(max((-h_t - s0) / ds, 0.0), 1.0)
        t1 = min(max((h_t - s0) / ds, 0.0), 1.0)
        lo, hi = min(t0, t1), max(t0, t1)
    plx, ply = e0x + lo * (e1x - e0x), e0y + lo * (e1y - e0y)
    phx, phy = e0x + hi * (e1x - e0x), e0y + hi * (e1y - e0y)
    w_lo = max(h_n - ((plx - rc[0]) * n_ref[0] + (ply - rc[1]) * n_ref[1]), 0.0)
    w_hi = max(h_n - ((phx - rc[0]) * n_ref[0] + (phy - rc[1]) * n_ref[1]), 0.0)
    total = w_lo + w_hi
    mix = w_hi / total if total > 1e-12 else 0.5
    return least, nx, ny, plx + mix * (phx - plx), ply + mix * (phy - ply)


@nb.njit(cache=True, parallel=True)
def substeps(
    state: tuple,
    half_w: NDArray[np.float64],
    half_l: NDArray[np.float64],
    mass: NDArray[np.float64],
    radius: NDArray[np.float64],
    offset: NDArray[np.float64],
    goal_radius: NDArray[np.float64],
    goal_mass: NDArray[np.float64],
    lim: float,
    h: float,
    n_sub: int,
    damping: float,
    share_rot: float,
    goal_wall_friction: float,
    robot_wall_friction: float,
) -> None:
    """Every match's `n_sub` substeps of h seconds, in place (sim.fast.world.FastWorld.step).
    state: (x, y, heading, rvx, rvy, rw, gx, gy, gvx, gvy, carried, carrier, contester): carried
    (B, R) the goal each robot's clamp moves (-1 none: a tug of war's loser is dragged after the
    step), carrier and contester (B, G) the robots holding each goal (neither meets it); offset
    (R, G): each robot's signed clamp offset for each goal (negative: behind its back)."""
    x, y, heading, rvx, rvy, rw, gx, gy, gvx, gvy, carried, carrier, contester = state
    n_match, n_robot = x.shape
    n_goal = gx.shape[1]
    k = n_robot + n_goal
    inertia = mass * ((2 * half_w) ** 2 + (2 * half_l) ** 2) / 12.0
    cap = n_robot * n_robot + n_robot * n_goal + n_goal * n_goal
    for b in nb.prange(n_match):
        c_n = np.empty((cap, 2))
        c_d = np.empty(cap)
        c_p = np.empty((cap, 2))
        c_a = np.empty(cap, dtype=np.int64)
        c_c = np.empty(cap, dtype=np.int64)
        acc = np.zeros((k, 6))  # dx, dy, dvx, dvy, turn speed, turn position
        wall = np.zeros((k, 2), dtype=np.int64)
        for _ in range(n_sub):
            for i in range(n_robot):
                x[b, i] += rvx[b, i] * h
                y[b, i] += rvy[b, i] * h
                heading[b, i] += math.degrees(rw[b, i]) * h
            for g in range(n_goal):
                speed = math.hypot(gvx[b, g], gvy[b, g])
                damp = max(0.0, 1.0 - damping * (1.0 + speed) * h)
                gvx[b, g] *= damp
                gvy[b, g] *= damp
                if carrier[b, g] < 0:
                    gx[b, g] += gvx[b, g] * h
                    gy[b, g] += gvy[b, g] * h
            _follow(b, x, y, heading, rvx, rvy, gx, gy, gvx, gvy, carried, offset)
            # Contacts, all from this one state (then summed, as the numpy model did).
            m = 0
            for i in range(n_robot):
                for j in range(i + 1, n_robot):
                    dx, dy = x[b, j] - x[b, i], y[b, j] - y[b, i]
                    if dx * dx + dy * dy >= (radius[i] + radius[j]) ** 2:
                        continue
                    least, nx, ny, px, py = _box_contact(b, i, j, x, y, heading, half_w, half_l)
                    if least > 0:
                        c_n[m, 0], c_n[m, 1], c_d[m] = nx, ny, least
                        c_p[m, 0], c_p[m, 1], c_a[m], c_c[m] = px, py, i, j
                        m += 1
            for i in range(n_robot):
                hr = math.radians(heading[b, i])
                fx, fy = math.sin(hr), math.cos(hr)
                rx, ry = fy, -fx
                for g in range(n_goal):
                    if carrier[b, g] == i or contester[b, g] == i:
                        continue
                    dx, dy = gx[b, g] - x[b, i], gy[b, g] - y[b, i]
                    if dx * dx + dy * dy >= (radius[i] + goal_radius[g]) ** 2:
                        continue
                    lx, ly = dx * rx + dy * ry, dx * fx + dy * fy
                    hw, hl = half_w[i], half_l[i]
                    px, py = min(max(lx, -hw), hw), min(max(ly, -hl), hl)
                    ex, ey = lx - px, ly - py
                    dist = math.hypot(ex, ey)
                    gr = goal_radius[g]
                    if dist < 1e-9:
                        if hw - abs(lx) <= hl - abs(ly):
                            nlx, nly = (1.0 if lx >= 0 else -1.0), 0.0
                            depth = hw - abs(lx) + gr
                        else:
                            nlx, nly = 0.0, (1.0 if ly >= 0 else -1.0)
                            depth = hl - abs(ly) + gr
                    else:
                        nlx, nly = ex / dist, ey / dist
                        depth = gr - dist
                    if depth <= 0:
                        continue
                    c_n[m, 0] = nlx * rx + nly * fx
                    c_n[m, 1] = nlx * ry + nly * fy
                    c_d[m] = depth
                    c_p[m, 0] = x[b, i] + px * rx + py * fx
                    c_p[m, 1] = y[b, i] + px * ry + py * fy
                    c_a[m], c_c[m] = i, n_robot + g
                    m += 1
            for a in range(n_goal):
                for c in range(a + 1, n_goal):
                    dx, dy = gx[b, c] - gx[b, a], gy[b, c] - gy[b, a]
                    reach = goal_radius[a] + goal_radius[c]
                    if dx * dx + dy * dy >= reach * reach:
                        continue
                    dist = math.hypot(dx, dy)
                    if dist > 1e-12:
                        nx, ny = dx / dist, dy / dist
                    else:
                        nx, ny = 1.0, 0.0
                    c_n[m, 0], c_n[m, 1], c_d[m] = nx, ny, reach - dist
                    c_p[m, 0] = gx[b, a] + nx * goal_radius[a]
                    c_p[m, 1] = gy[b, a] + ny * goal_radius[a]
                    c_a[m], c_c[m] = n_robot + a, n_robot + c
                    m += 1
            if m:
                # Which wall each body stands against (before this step's pushes).
                for q in range(k):
                    if q < n_robot:
                        hr = math.radians(heading[b, q])
                        fx, fy = math.sin(hr), math.cos(hr)
                        ex = half_l[q] * abs(fx) + half_w[q] * abs(fy)
                        ey = half_l[q] * abs(fy) + half_w[q] * abs(fx)
                        qx, qy = x[b, q], y[b, q]
                    else:
                        ex = ey = goal_radius[q - n_robot]
                        qx, qy = gx[b, q - n_robot], gy[b, q - n_robot]
                    edge = lim - 1e-4
                    wall[q, 0] = 1 if qx + ex >= edge else (-1 if qx - ex <= -edge else 0)
                    wall[q, 1] = 1 if qy + ey >= edge else (-1 if qy - ey <= -edge else 0)
                acc[:] = 0.0
                for e in range(m):
                    pa, pc = c_a[e], c_c[e]
                    nx, ny = c_n[e, 0], c_n[e, 1]
                    props = np.empty((2, 9))
                    for side in range(2):
                        q = pa if side == 0 else pc
                        if q < n_robot:
                            props[side, 0] = 1.0 / mass[q]
                            props[side, 1] = 1.0 / inertia[q]
                            props[side, 2], props[side, 3] = x[b, q], y[b, q]
                            props[side, 4], props[side, 5] = rvx[b, q], rvy[b, q]
                            props[side, 6] = rw[b, q]
                        else:
                            g = q - n_robot
                            props[side, 0] = 1.0 / goal_mass[g]
                            props[side, 1] = 0.0
                            props[side, 2], props[side, 3] = gx[b, g], gy[b, g]
                            props[side, 4], props[side, 5] = gvx[b, g], gvy[b, g]
                            props[side, 6] = 0.0
                        # Against a wall and pushed toward it: it stands like the wall across
                        # it (props 7 and 8: whether it moves along x and along y) and slides
                        # along it; in a corner it stands.
                        dxs, dys = (-nx, -ny) if side == 0 else (nx, ny)
                        free_x = not (wall[q, 0] != 0 and dxs * wall[q, 0] > 1e-6)
                        free_y = not (wall[q, 1] != 0 and dys * wall[q, 1] > 1e-6)
                        props[side, 7] = 1.0 if free_x else 0.0
                        props[side, 8] = 1.0 if free_y else 0.0
                        if not (free_x and free_y):
                            props[side, 1] = 0.0
                    inv_a = props[0, 0] * (nx * nx * props[0, 7] + ny * ny * props[0, 8])
                    inv_c = props[1, 0] * (nx * nx * props[1, 7] + ny * ny * props[1, 8])
                    if inv_a <= 1e-12 and inv_c <= 1e-12:
                        # Both held: both give way, by mass (as neither were held).
                        for side in range(2):
                            q = pa if side == 0 else pc
                            props[side, 0] = 1.0 / (
                                mass[q] if q < n_robot else goal_mass[q - n_robot]
                            )
                            props[side, 1] = 1.0 / inertia[q] if q < n_robot else 0.0
                            props[side, 7] = props[side, 8] = 1.0
                        inv_a, inv_c = props[0, 0], props[1, 0]
                    lever = not math.isnan(c_p[e, 0])
                    ax = c_p[e, 0] - props[0, 2] if lever else 0.0
                    ay = c_p[e, 1] - props[0, 3] if lever else 0.0
                    cx = c_p[e, 0] - props[1, 2] if lever else 0.0
                    cy = c_p[e, 1] - props[1, 3] if lever else 0.0
                    a_n, cc_n = ax * ny - ay * nx, cx * ny - cy * nx
                    rel = (props[1, 4] + props[1, 6] * cy - props[0, 4] - props[0, 6] * ay) * nx + (
                        props[1, 5] - props[1, 6] * cx - props[0, 5] + props[0, 6] * ax
                    ) * ny
                    ia, ic = props[0, 1], props[1, 1]
                    eff = inv_a + inv_c + a_n * a_n * ia + cc_n * cc_n * ic
                    j = -rel / eff if rel < 0 else 0.0
                    share = share_rot * c_d[e] / eff
                    move = share + (1.0 - share_rot) * c_d[e] / (inv_a + inv_c)
                    # Each side moves along the contact normal where it is free to; one pressed
                    # against a wall slides along it against the wall's friction.
                    for side in range(2):
                        q = pa if side == 0 else pc
                        sign = -1.0 if side == 0 else 1.0
                        mu = goal_wall_friction if q >= n_robot else robot_wall_friction
                        dx_, dy_ = _slide(
                            sign * move * props[side, 0] * nx,
                            sign * move * props[side, 0] * ny,
                            props[side, 7], props[side, 8], mu,
                        )  # fmt: skip
                        acc[q, 0] += dx_
                        acc[q, 1] += dy_
                        dvx, dvy = _slide(
                            sign * j * props[side, 0] * nx,
                            sign * j * props[side, 0] * ny,
                            props[side, 7], props[side, 8], mu,
                        )  # fmt: skip
                        acc[q, 2] += dvx
                        acc[q, 3] += dvy
                    acc[pa, 4] += j * a_n * ia
                    acc[pc, 4] -= j * cc_n * ic
                    acc[pa, 5] += share * a_n * ia
                    acc[pc, 5] -= share * cc_n * ic
                for i in range(n_robot):
                    x[b, i] += acc[i, 0]
                    y[b, i] += acc[i, 1]
                    heading[b, i] += math.degrees(acc[i, 5])
                    rvx[b, i] += acc[i, 2]
                    rvy[b, i] += acc[i, 3]
                    rw[b, i] += acc[i, 4]
                for g in range(n_goal):
                    if carrier[b, g] < 0:
                        q = n_robot + g
                        gx[b, g] += acc[q, 0]
                        gy[b, g] += acc[q, 1]
                        gvx[b, g] += acc[q, 2]
                        gvy[b, g] += acc[q, 3]
                _follow(b, x, y, heading, rvx, rvy, gx, gy, gvx, gvy, carried, offset)
            _walls(
                b, x, y, heading, rvx, rvy, rw, gx, gy, gvx, gvy, carried, carrier,
                half_w, half_l, mass, inertia, radius, offset, goal_radius, lim, share_rot,
            )  # fmt: skip
            _follow(b, x, y, heading, rvx, rvy, gx, gy, gvx, gvy, carried, offset)


@nb.njit(cache=True)
def _walls(b, x, y, heading, rvx, rvy, rw, gx, gy, gvx, gvy, carried, carrier,
           half_w, half_l, mass, inertia, radius, offset, goal_radius, lim, share_rot):  # fmt: skip
    """The walls: a robot's deepest corner past one is stopped and moved out through mass and
    inertia (share_rot of it), then every robot with the goal it carries, and every free goal,
    is put inside."""
    for i in range(x.shape[1]):
        if max(abs(x[b, i]), abs(y[b, i])) + radius[i] <= lim:
            continue
        hr = math.radians(heading[b, i])
        fx, fy = math.sin(hr), math.cos(hr)
        rx, ry = fy, -fx
        px_, py_ = np.empty(4), np.empty(4)
        for q in range(4):
            sa = 1.0 if q < 2 else -1.0
            sb = 1.0 if q == 0 or q == 3 else -1.0
            px_[q] = x[b, i] + sa * half_l[i] * fx + sb * half_w[i] * rx
            py_[q] = y[b, i] + sa * half_l[i] * fy + sb * half_w[i] * ry
        m, inert = mass[i], inertia[i]
        turn = 0.0
        for axis in range(2):
            for side in (-1.0, 1.0):
                best, depth = 0, -math.inf
                for q in range(4):
                    pen = side * (px_[q] if axis == 0 else py_[q]) - lim
                    if pen > depth:
                        best, depth = q, pen
                if not depth > 0:
                    continue
                ax, ay = px_[best] - x[b, i], py_[best] - y[b, i]
                nx, ny = (-side, 0.0) if axis == 0 else (0.0, -side)
                rxn = ax * ny - ay * nx
                eff = 1.0 / m + rxn * rxn / inert
                u = (rvx[b, i] + rw[b, i] * ay) * nx + (rvy[b, i] - rw[b, i] * ax) * ny
                if u < 0:
                    j = -u / eff
                    rvx[b, i] += j * nx / m
                    rvy[b, i] += j * ny / m
                    rw[b, i] -= rxn * j / inert
                push = share_rot * depth / eff
                x[b, i] += push * nx / m
                y[b, i] += push * ny / m
                turn -= rxn * push / inert
                for q in range(4):
                    px_[q] += push * nx / m
                    py_[q] += push * ny / m
        heading[b, i] += math.degrees(turn)
    for i in range(x.shape[1]):
        hr = math.radians(heading[b, i])
        fx, fy = math.sin(hr), math.cos(hr)
        ex = half_l[i] * abs(fx) + half_w[i] * abs(fy)
        ey = half_l[i] * abs(fy) + half_w[i] * abs(fx)
        lo_x, hi_x, lo_y, hi_y = x[b, i] - ex, x[b, i] + ex, y[b, i] - ey, y[b, i] + ey
        g = carried[b, i]
        if g >= 0:
            cx, cy = _clamp_point(x[b, i], y[b, i], heading[b, i], offset[i, g])
            r = goal_radius[g]
            lo_x, hi_x = min(lo_x, cx - r), max(hi_x, cx + r)
            lo_y, hi_y = min(lo_y, cy - r), max(hi_y, cy + r)
        x[b, i] += max(0.0, -lim - lo_x) - max(0.0, hi_x - lim)
        y[b, i] += max(0.0, -lim - lo_y) - max(0.0, hi_y - lim)
    for g in range(gx.shape[1]):
        if carrier[b, g] >= 0:
            continue
        gl = lim - goal_radius[g]
        nx_, ny_ = min(max(gx[b, g], -gl), gl), min(max(gy[b, g], -gl), gl)
        if nx_ != gx[b, g]:
            gvx[b, g] = 0.0
        if ny_ != gy[b, g]:
            gvy[b, g] = 0.0
        gx[b, g], gy[b, g] = nx_, ny_
