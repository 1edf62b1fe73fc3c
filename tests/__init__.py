"""The test suite. `robot` is imported first: it picks the offscreen GL before any test imports mujoco."""

import robot  # noqa: F401
