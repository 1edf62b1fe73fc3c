"""The robot's core, shared by every body (the MuJoCo simulation, the real robot): the control loop, the safety
latch, the joint arbiter, the motion inbox, the per-tick sequence and the state publisher."""
