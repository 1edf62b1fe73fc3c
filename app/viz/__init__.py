"""What is drawn in 3D: the live mirrors, the session replay, their overlays, gates and clicks."""
