"""The simulated field, in four modules (import them directly; this package re-exports nothing):

sim.world.state     plain data: DriveCommand, GpsReading, RobotState, GoalState, StepEvents,
                    AllianceScore, the RING_* states, WorldState (what rules and sensors read)
sim.world.rules     the game's rules: score, goal ownership, elevation, pins
sim.world.sensors   GPS, camera pose, obstacles and the rings a camera sees
sim.world.physics   World: the PyBullet bodies, reset and step; calls rules and sensors
"""
