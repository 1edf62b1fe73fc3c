"""Running on the robot's own computer: the systemd service, `humanoid doctor`, database backups on upgrade."""
