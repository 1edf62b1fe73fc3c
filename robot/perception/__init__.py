"""Perception: the head RGB-D camera, object detection and 3D localisation, the lidar, the occupancy map."""
