"""Robot side of the humanoid mission-control app.

Everything here is importable without the web side (`app/`): the worker owns the simulation or the servo bus
and talks to the outside world only through `robot.interface`.
"""
