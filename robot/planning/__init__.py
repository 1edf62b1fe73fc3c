"""Turning commands into plans, checking them, and executing them."""
