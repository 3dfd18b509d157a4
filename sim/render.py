"""Top-down pictures of a World with Pillow: field, zones, goals, rings, robots, camera frustums.

Drawn from the simulator's state directly (no PyBullet render), so it costs a millisecond or two
and looks the same in both fidelities. In the whole game (`game = "tipping_point"`) the picture
also shows each platform's tilt (the hinge, the lowered half shaded, the angle, "BAL" while
Balanced), each goal's owner right now (its outline in the colour of the alliance it scores for,
thicker when Elevated) and its rings as high/low/base, an Elevated robot (a white frame inside its
outline), and the caption gives the period, both alliances' scores and their fouls. The ring
race's pictures are drawn as they always were.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from jetson.autonomy.camera import robot_to_camera_rotation
from jetson.autonomy.geometry import box_corners, robot_to_field
from sim.config import CameraConfig
from sim.world import rules, sensors
from sim.world.physics import World
from sim.world.state import RING_FLOOR, GoalState

Px = Callable[[float, float], tuple[float, float]]

_RED = (200, 40, 45)
_BLUE = (30, 80, 190)
_VISIBLE = (255, 255, 255)
_NEUTRAL = (235, 235, 235)


def _alliance_rgb(alliance: str | None) -> tuple[int, int, int]:
    return _RED if alliance == "red" else _BLUE if alliance == "blue" else _NEUTRAL


def goal_label(high: int, low: int, base: int) -> str:
    """A goal's rings in the whole game's picture: high/low/base, without the parts it lacks
    ("3" for three on the low branches, "2/3/1" with a high branch, "3/1" with a base)."""
    if high:
        return f"{high}/{low}/{base}"
    if base:
        return f"{low}/{base}"
    return str(low) if low else ""


def game_caption(world: World) -> str:
    """The whole game's caption: time, period, each alliance's score, fouls, win point."""
    s = world.score()
    parts = [f"t {world.time_s:5.1f} s  {world.phase}"]
    for alliance in ("red", "blue"):
        a = s[alliance]
        extra = " AWP" if a.autonomous_win_point else ""
        parts.append(f"{alliance} {a.total:3d} (fouls {a.fouls}{extra})")
    return "   ".join(parts)


def _draw_platforms(d: ImageDraw.ImageDraw, world: World, px: Px) -> None:
    """Each see-saw: the hinge, the half whose edge is down shaded by how far, the tilt in
    degrees and BAL while Balanced."""
    f = world.field
    for plat in f.platforms:
        state = world.platforms.get(plat.alliance)
        if state is None:
            continue
        cx, cy = plat.center
        sx, sy = plat.size
        full = plat.max_tilt_rad or 1.0
        share = min(1.0, abs(state.tilt) / full)
        # Positive tilt: the field-side edge is down.
        down = plat.field_side if state.tilt > 0 else -plat.field_side
        if share > 1e-3:
            x0, x1 = sorted((cx, cx + down * sx / 2))
            d.rectangle(
                [px(x0, cy + sy / 2), px(x1, cy - sy / 2)], fill=(0, 0, 0, round(40 + 110 * share))
            )
        d.line([px(cx, cy + sy / 2), px(cx, cy - sy / 2)], fill=(250, 250, 250), width=2)
        balanced = rules.platform_balanced(world, plat.alliance)
        text = f"{math.degrees(state.tilt):+.0f}" + (" BAL" if balanced else "")
        tx, ty = px(cx - sx / 2, cy - sy / 2)
        d.text((tx + 2, ty - 12), text, fill=(255, 255, 255))


def _draw_goal_game(
    d: ImageDraw.ImageDraw, world: World, g: GoalState, cx: float, cy: float, rad: float
) -> None:
    """A goal's owner (its outline) and rings (high/low/base) in the whole game."""
    owner, elevated = rules.goal_owner(world, g)
    if owner is not None:
        width = 4 if elevated else 2
        d.ellipse(
            [cx - rad - 3, cy - rad - 3, cx + rad + 3, cy + rad + 3],
            outline=_alliance_rgb(owner),
            width=width,
        )
    label = goal_label(g.rings_high, g.rings_low, g.rings_base)
    if label:  # below a tall goal's post
        dy = 2 if g.spec.kind == "neutral_tall" else -6
        d.text((cx - 3 * len(label), cy + dy), label, fill=(0, 0, 0))


def _frustum_polygon(cam: CameraConfig, ring_z: float) -> np.ndarray:
    """The floor area a camera sees, in the robot frame (x right, y forward)."""
    rot = robot_to_camera_rotation(cam.tilt_deg).T  # optical -> robot
    origin = np.array([cam.right_m, cam.forward_m, cam.height_m])
    pts = []
    for u, v in ((0, cam.height), (cam.width, cam.height), (cam.width, 0), (0, 0)):
        ray = rot @ np.array([(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0])
        horizontal = math.hypot(ray[0], ray[1])
        drop = origin[2] - ring_z
        if ray[2] < -1e-6:
            t = drop / -ray[2]
            if t * math.sqrt(horizontal**2 + ray[2] ** 2) > cam.max_range_m:
                t = cam.max_range_m / math.sqrt(horizontal**2 + ray[2] ** 2)
        else:
            t = cam.max_range_m / math.sqrt(horizontal**2 + ray[2] ** 2)
        pts.append(origin[:2] + t * ray[:2])
    return np.array(pts)


def top_down(
    world: World,
    size: int = 480,
    visible: Sequence[np.ndarray] | None = None,
    show_frustum: bool = True,
    title: str | None = None,
) -> np.ndarray:
    """An RGB image (size x size + a caption strip) of the field seen from above.

    visible: per robot, ring indices to outline (default: each robot's visible_rings()).
    """
    f = world.field
    half = f.half
    margin = 8
    scale = (size - 2 * margin) / f.size
    caption = 22
    img = Image.new("RGB", (size, size + caption), (30, 30, 34))
    d = ImageDraw.Draw(img, "RGBA")

    def px(x: float, y: float) -> tuple[float, float]:
        return (margin + (x + half) * scale, margin + (half - y) * scale)

    d.rectangle([px(-half, half), px(half, -half)], fill=f.tile_rgb)
    for k in range(1, round(f.size / f.tile)):
        c = -half + k * f.tile
        d.line([px(c, -half), px(c, half)], fill=(110, 110, 112), width=1)
        d.line([px(-half, c), px(half, c)], fill=(110, 110, 112), width=1)
    for alliance, zone in f.home_zones.items():
        tint = (*(_RED if alliance == "red" else _BLUE), 40)
        d.rectangle([px(zone.x0, zone.y1), px(zone.x1, zone.y0)], fill=tint)
    for x0, y0, x1, y1 in f.lines:
        d.line([px(x0, y0), px(x1, y1)], fill=f.line_rgb, width=2)
    for plat in f.platforms:
        cx, cy = plat.center
        sx, sy = plat.size
        d.rectangle(
            [px(cx - sx / 2, cy + sy / 2), px(cx + sx / 2, cy - sy / 2)],
            fill=(*plat.rgb, 150),
            outline=(20, 20, 20),
        )
    game = rules.whole_game(world)
    if game:
        _draw_platforms(d, world, px)
    d.rectangle([px(-half, half), px(half, -half)], outline=f.wall_rgb, width=3)

    if visible is None:
        visible = [sensors.visible_rings(world, i) for i in range(len(world.robots))]
    seen = set()
    for v in visible:
        seen.update(int(i) for i in v)

    if show_frustum:
        for r in world.robots:
            poly = _frustum_polygon(r.config.camera, float(f.ring.thickness / 2))
            field_poly = robot_to_field(poly, r.xy, r.heading)
            col = _RED if r.alliance == "red" else _BLUE
            d.polygon([px(*q) for q in field_poly], fill=(*col, 35), outline=(*col, 160))

    ring_r = max(2.0, f.ring.radius * scale)
    for i in np.flatnonzero(world.ring_state == RING_FLOOR):
        x, y = world.ring_xy[i]
        cx, cy = px(x, y)
        outline = _VISIBLE if int(i) in seen else (70, 30, 90)
        d.ellipse(
            [cx - ring_r, cy - ring_r, cx + ring_r, cy + ring_r],
            fill=f.ring.rgb,
            outline=outline,
            width=2 if int(i) in seen else 1,
        )

    for g in world.goals:
        cx, cy = px(g.x, g.y)
        rad = g.spec.base_radius * scale
        d.regular_polygon((cx, cy, rad), 7, fill=g.spec.rgb, outline=(20, 20, 20))
        if g.spec.kind == "neutral_tall":
            d.ellipse([cx - 3, cy - 3, cx + 3, cy + 3], fill=(20, 20, 20))
        if game:
            _draw_goal_game(d, world, g, cx, cy, rad)
        elif g.rings:
            d.text((cx - 4, cy - 6), str(g.rings), fill=(0, 0, 0))

    for r in world.robots:
        rc = r.config
        col = _RED if r.alliance == "red" else _BLUE
        corners = box_corners(r.xy, r.heading, rc.width_m, rc.length_m)
        d.polygon([px(*q) for q in corners], fill=rc.rgb, outline=col, width=3)
        if game and rules.robot_elevated(world, r):  # a white frame inside its own
            inner = box_corners(r.xy, r.heading, rc.width_m * 0.8, rc.length_m * 0.8)
            d.polygon([px(*q) for q in inner], outline=(255, 255, 255), width=2)
        (x0, x1), (y0, y1) = world.intake_rect(r)
        intake = robot_to_field(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]), r.xy, r.heading)
        d.polygon([px(*q) for q in intake], outline=(*f.ring.rgb, 255))
        nose = robot_to_field(np.array([[0.0, rc.length_m / 2]]), r.xy, r.heading)[0]
        d.line([px(*r.xy), px(*nose)], fill=col, width=3)
        cx, cy = px(*r.xy)
        d.text((cx - 4, cy - 6), str(r.held), fill=(255, 255, 255))

    if title:
        text = title
    elif game:
        text = game_caption(world)
    else:
        score = world.score()
        text = (
            f"t {world.time_s:5.1f} s   red {score['red'].total:3d}   "
            f"blue {score['blue'].total:3d}   "
            + "  ".join(f"{r.name}: {r.collected}" for r in world.robots)
        )
    d.text((margin, size + 4), text, fill=(235, 235, 235))
    return np.asarray(img)


def save_png(image: np.ndarray, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(image).save(path)
    return path


def save_gif(frames: Sequence[np.ndarray], path: str | Path, fps: float = 12.0) -> Path:
    if not frames:
        raise ValueError("save_gif needs at least one frame")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images = [Image.fromarray(f) for f in frames]
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=max(20, round(1000 / fps)),
        loop=0,
        optimize=False,
    )
    return path
