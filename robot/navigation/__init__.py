"""Navigation: paths on an occupancy grid and following them through the walking controller's velocity input."""
