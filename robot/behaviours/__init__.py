"""Behaviours: long-running missions (fetch, tour, patrol, demo, and any a user's package adds) built on the
robot's skills, run by the task runner as a plan is. `api` is what a behaviour is written against; `registry`
finds them (entry points `humanoid.behaviours`); `runner` runs them, contained; `robot_view` is the robot as their
code sees it."""
