"""Web side of the humanoid mission-control app: FastAPI server, viser mirror, sessions DB, CLI."""
