"""Pac-Man Pete's simulator: a PyBullet twin of the Tipping Point field and its environments.

Light modules (numpy only, what the Jetson imports): jetson.autonomy.geometry, jetson.autonomy.spec, sim.config,
sim.field, sim.visibility. PyBullet modules: sim.world, sim.camera, sim.scripted, sim.match,
sim.env (Gymnasium, registers pete/TippingPoint-v0), sim.parallel_env (PettingZoo). Importing
this package imports none of them.
"""
