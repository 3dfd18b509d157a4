"""Training the robot's policy: configs, rollouts on several processes, self-play, the PPO loop,
checkpoints and export. The algorithm itself is sim.ppo; the exported policy runs through
jetson.autonomy.policy (onnxruntime only)."""
