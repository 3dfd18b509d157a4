"""Players that are not the learned policy, to measure it against (import the modules directly):

sim.baselines.planner    the route planner: pure pursuit over the rings its camera has seen
sim.baselines.scripted   the greedy ring-chaser on ground-truth rings, the stock opponent
sim.baselines.original   the original team's ONNX policy, adapted to their 25 inputs
"""
