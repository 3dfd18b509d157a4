"""Which mobile goals a robot's camera sees, as the robot's goal detector reports them.

The robot's classical goal detector (jetson/perception/goals.py) finds goals by the colour of
their bases (neutral goals yellow, alliance goals red or blue) and places each on the floor with
the depth image, in the robot frame. The twin gives the same report without rendering: a goal is
seen when the middle of its base (at half the base's height) projects inside the image and lies
between the near plane and the camera's range (sim.visibility.in_frustum, the one camera model),
and, in training fidelity, no robot stands in the way (sim.visibility.visible with the robots as
obstacles); high fidelity asks PyBullet's ray test. The camera sees nothing while the robot turns
faster than its `max_turn_rate_rad_s`, as for rings.

A report is (N, 3): x, y in the robot frame (metres, x right, y forward) and the colour code
(jetson.autonomy.goal_colours.GOAL_COLOUR_CODES: 0 yellow, 1 red, 2 blue).
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from jetson.autonomy.geometry import field_to_robot
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES as COLOUR_CODES
from sim.visibility import Obstacles, in_frustum, visible
from sim.world.sensors import camera_pose
from sim.world.state import WorldState


def goal_colour(alliance: str | None) -> int:
    """The colour code of a goal's base: yellow for a neutral goal, else its alliance's colour."""
    return COLOUR_CODES["yellow" if alliance is None else alliance]


def _robots_as_obstacles(world: WorldState, index: int) -> Obstacles:
    boxes = [
        (r.x, r.y, r.heading, r.config.width_m / 2, r.config.length_m / 2, r.config.height_m)
        for r in world.robots
        if r.index != index
    ]
    return Obstacles.build(boxes, [])


def visible_goals(world: WorldState, index: int) -> np.ndarray:
    """The goals robot `index`'s camera sees now: (N, 3) x, y robot frame and colour code."""
    r = world.robots[index]
    cam = r.config.camera
    out = np.zeros((0, 3))
    if not world.goals:
        return out
    if cam.max_turn_rate_rad_s is not None and abs(r.w) > cam.max_turn_rate_rad_s:
        return out
    pts = np.array([(g.x, g.y, g.spec.base_height / 2) for g in world.goals], dtype=np.float64)
    pose = camera_pose(world, index)
    if world.training:
        mask = visible(pts, pose, cam, _robots_as_obstacles(world, index))
    else:
        mask, _, _ = in_frustum(pts, pose, cam)
        keep = np.flatnonzero(mask)
        if len(keep):
            hits = p.rayTestBatch(
                [tuple(pose.position)] * len(keep),
                [tuple(pts[k]) for k in keep],
                physicsClientId=world.client,
            )
            for k, hit in zip(keep, hits, strict=True):
                mask[k] = hit[0] in (-1, r.body, world.goals[k].body)
    seen = np.flatnonzero(mask)
    if not len(seen):
        return out
    xy = field_to_robot(pts[seen, :2], (r.x, r.y), r.heading)
    colour = np.array([goal_colour(world.goals[k].spec.alliance) for k in seen], dtype=np.float64)
    return np.column_stack([xy, colour])
