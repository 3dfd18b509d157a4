"""The simulated field, in five modules (import them directly; this package re-exports nothing):

sim.world.state     plain data: DriveCommand, GpsReading, RobotState, GoalState, StepEvents,
                    AllianceScore, Foul, AutonomousResult, PlatformState, the RING_* states,
                    WorldState (what rules and sensors read)
sim.world.rules     the game's rules: score, goal ownership, elevation, balance, pins, fouls,
                    the autonomous bonus and win point (the ring race or the whole game)
sim.world.seesaw    the whole game's platform as a see-saw: who is on a board, its tilt
sim.world.sensors   GPS, camera pose, obstacles and the rings a camera sees
sim.world.physics   World: the PyBullet bodies, reset and step; calls rules and sensors
"""
