"""`humanoid doctor`: checks this machine before the robot's first run and says what to fix, one line each."""
