"""Robot side of the humanoid mission-control app.

Everything here is importable without the web side (`app/`): the worker owns the simulation or the servo bus
and talks to the outside world only through `robot.interface`.
"""

import os

# Offscreen rendering for the simulated camera: EGL (Debian's libegl1, software rendering when there is no GPU).
# mujoco reads this when it is first imported, so it is set here, before any module of the package imports it;
# MUJOCO_GL=osmesa (with libosmesa6) works too.
os.environ.setdefault("MUJOCO_GL", "egl")
