"""Pac-Man Pete's simulator: a PyBullet twin of the Tipping Point field and its environments.

Light modules (numpy only): sim.config, sim.field, sim.visibility. PyBullet modules: sim.world
(physics, rules, sensors, state), sim.camera, sim.baselines, sim.match, sim.env (Gymnasium,
registers pete/TippingPoint-v0), sim.parallel_env (PettingZoo). The robot's own decision code
is jetson.autonomy, which this package imports and never the other way round. Importing this
package imports none of them.
"""
