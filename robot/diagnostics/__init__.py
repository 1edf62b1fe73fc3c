"""Diagnostics: each part of the robot and its computer checked against thresholds, at ROS-style levels
(OK / WARN / ERROR / STALE), with a safe stop when a fault makes motion unsafe."""
