"""Web side of the humanoid mission-control app: FastAPI server, viser mirror, sessions DB, CLI."""

import robot  # noqa: F401  (sets the offscreen GL before the mirror imports mujoco)
