"""`detect_object`: look for a known object, with the head first and then by turning the body; `look_around`:
look everywhere once, for whatever is there.

The search first looks where the object is believed to be (world memory, or the place the world says it is on),
then sweeps the head left and right at two tilts, then turns the body and sweeps again, until the object has
been seen in a frame taken after the head stopped moving, or the whole room has been looked at.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Protocol

from robot.interface import DetectedObject

# Head sweep (pan, tilt) in rad: ahead first, then to each side; then nearer the feet.
SWEEP = (
    (0.0, -0.35),
    (0.75, -0.35),
    (-0.75, -0.35),
    (1.35, -0.35),
    (-1.35, -0.35),
    (0.0, -0.8),
    (0.75, -0.8),
    (-0.75, -0.8),
)
# Body turns between sweeps: the head's +-1.35 rad plus the camera's +-0.76 rad cover about 240 deg per sweep.
BODY_TURNS = (math.radians(120.0), math.radians(120.0))
MIN_CONFIDENCE = 0.5
FRAMES_PER_VIEW = 2  # a detection must be in one of this many frames taken after the head stopped


class SearchBody(Protocol):
    """What the search needs from the robot (the worker implements it)."""

    def point_head(self, pan: float, tilt: float) -> None:
        """Aim the head and block until it is there and the image is steady."""

    def look_at(self, target: tuple[float, float, float]) -> bool:
        """Aim the head at a world point and block until there; False (head not moved) if out of its reach."""

    def face(self, target: tuple[float, float, float]) -> None:
        """Turn the body in place to face a world point (blocks)."""

    def turn_in_place(self, angle: float) -> None:
        """Turn the body by this angle (rad, counter-clockwise), blocking until standing again."""

    def fresh_detections(self) -> tuple[DetectedObject, ...]:
        """Detections of the next camera frame taken after this call."""


class ObjectNotFound(Exception):
    pass


@dataclass(frozen=True)
class SearchResult:
    detection: DetectedObject
    views: int  # camera views looked at
    turned_rad: float


def find_object(
    name: str, body: SearchBody, believed_at: tuple[float, float, float] | None, check_cancelled: Callable[[], None]
) -> SearchResult:
    """Find `name` (a canonical object name) or raise ObjectNotFound saying where it looked."""
    views = 0
    turned = 0.0

    def look() -> DetectedObject | None:
        nonlocal views
        views += 1
        for _ in range(FRAMES_PER_VIEW):
            check_cancelled()
            for detection in body.fresh_detections():
                if detection.label == name and detection.confidence >= MIN_CONFIDENCE:
                    return detection
        return None

    if believed_at is not None:
        if not body.look_at(believed_at):
            body.face(believed_at)
            body.look_at(believed_at)
        if found := look():
            return SearchResult(found, views, turned)
    for turned in _sweep(body, check_cancelled):
        if found := look():
            return SearchResult(found, views, turned)
    raise ObjectNotFound(
        f"{name} not found: looked in {views} directions"
        + (f" and turned {math.degrees(turned):.0f} deg" if turned else "")
    )


@dataclass(frozen=True)
class LookResult:
    seen: dict[str, DetectedObject]  # label -> its nearest confident detection
    views: int
    turned_rad: float


def look_around(body: SearchBody, check_cancelled: Callable[[], None]) -> LookResult:
    """Sweep the head at every body heading of a full turn (ending facing the way it started) and collect every
    confident detection. The world memory takes in what the frames show as they arrive; this says what was seen."""
    seen: dict[str, DetectedObject] = {}
    views = 0
    for _ in _sweep(body, check_cancelled):
        views += 1
        for _ in range(FRAMES_PER_VIEW):
            for detection in body.fresh_detections():
                known = seen.get(detection.label)
                if detection.confidence >= MIN_CONFIDENCE and (
                    known is None or detection.distance_m < known.distance_m
                ):
                    seen[detection.label] = detection
    turned = sum(BODY_TURNS)
    back = math.tau - turned  # the rest of the full turn: face the way the robot started
    if back > 1e-3:
        check_cancelled()
        body.turn_in_place(math.remainder(back, math.tau))
    body.point_head(0.0, SWEEP[0][1])
    return LookResult(seen, views, turned)


def _sweep(body: SearchBody, check_cancelled: Callable[[], None]) -> Iterator[float]:
    """Aim the head at every view of the sweep, at each body heading in turn; yields the body's turn so far once
    the head is there."""
    turned = 0.0
    for turn in (0.0, *BODY_TURNS):
        if turn:
            check_cancelled()
            body.turn_in_place(turn)
            turned += turn
        for pan, tilt in SWEEP:
            check_cancelled()
            body.point_head(pan, tilt)
            yield turned
