from __future__ import annotations

import numpy as np

from robot.control.posture import PostureController


def test_moves_at_a_capped_speed_and_settles() -> None:
    controller = PostureController(np.zeros(3), max_speed_rad_s=1.0)
    controller.move_to(np.array([0.5, -0.2, 0.0]))
    first = controller.update(0.01)
    assert np.allclose(first, [0.01, -0.01, 0.0])
    for _ in range(100):
        controller.update(0.01)
    assert controller.settled and np.allclose(controller.update(0.01), [0.5, -0.2, 0.0])


def test_freeze_stops_a_move_where_it_is() -> None:
    controller = PostureController(np.zeros(2), max_speed_rad_s=1.0)
    controller.move_to(np.array([1.0, 1.0]))
    for _ in range(10):
        controller.update(0.01)
    held = controller.freeze()
    assert np.allclose(held, [0.1, 0.1])
    for _ in range(50):
        assert np.allclose(controller.update(0.01), held)


def test_a_move_may_go_slower_than_the_cap_and_the_next_one_is_back_at_the_cap() -> None:
    controller = PostureController(np.zeros(1), max_speed_rad_s=1.5)
    controller.move_to(np.array([1.0]), max_speed_rad_s=0.4)
    assert np.allclose(controller.update(0.1), [0.04])
    controller.move_to(np.array([0.0]))
    assert np.allclose(controller.update(0.01), [0.025])
