"""The training fidelity's stand-ins for what it leaves out, shared by sim.world.physics.World
(training) and the batched backend (sim.fast), so the two model them with the same numbers.

Training fidelity is planar: no gravity, no floor, one velocity set per robot per control step.
High fidelity's robots are driven at 240 Hz against gravity and a floor; these make training
fidelity's pushes end where high fidelity's do (docs/notes/2026-11-29-goal-pushes.md): a robot
pushing a goal drives on at its commanded speed, and a goal it lets go of stops within a few
centimetres, not a third of a metre further on.
"""

# A goal's drag, d (1 + |v|) v per unit mass: PyBullet's multibody damping (Bullet's btMultiBody
# uses the damping as both DAMPING_K1_LINEAR and DAMPING_K2_LINEAR), integrated each substep.
GOAL_DAMPING = 0.99
# The floor's friction on a free goal: a deceleration (m/s^2) taken off its planar speed once a
# control step, after the physics substeps (to rest at most).
GOAL_FLOOR_DECEL = 3.0
# A robot's body mass over its RobotConfig.mass_kg: its drive holds its speed against a goal's
# friction as high fidelity's velocity control at 240 Hz does (robots against robots keep their
# mass ratio, so their pushes are unchanged).
ROBOT_DRIVE_MASS = 5.0
