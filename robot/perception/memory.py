"""World memory: where each known object was last seen, and on which named place.

Fed with every camera frame's detections; read by the planner (the world context) and shown to the operator.
An object is placed on a place when its base lies on that place's surface (within a margin).
"""

from __future__ import annotations

import threading

from robot.interface import DetectedObject, KnownObject
from robot.model.world import WorldLayout

# A detection below this confidence does not move what is remembered.
MIN_CONFIDENCE = 0.5
SURFACE_MARGIN_M = 0.05
SURFACE_HEIGHT_TOLERANCE_M = 0.04


class WorldMemory:
    def __init__(self, layout: WorldLayout) -> None:
        self._places = [p for p in layout.places if p.surface is not None]
        self._objects: dict[str, KnownObject] = {}
        self._lock = threading.Lock()

    def observe(self, detections: tuple[DetectedObject, ...], sim_time_s: float) -> list[KnownObject]:
        """Remember these detections; returns the objects whose remembered place changed (or that are new)."""
        changed = []
        with self._lock:
            for detection in detections:
                if detection.confidence < MIN_CONFIDENCE:
                    continue
                before = self._objects.get(detection.label)
                known = KnownObject(
                    detection.label,
                    detection.position,
                    self.place_of(detection.position),
                    sim_time_s,
                    detection.confidence,
                )
                self._objects[detection.label] = known
                if before is None or before.place != known.place:
                    changed.append(known)
        return changed

    def place_of(self, position: tuple[float, float, float]) -> str | None:
        x, y, z = position
        for place in self._places:
            surface = place.surface
            assert surface is not None
            if surface.contains(x, y, SURFACE_MARGIN_M) and abs(z - surface.height) < SURFACE_HEIGHT_TOLERANCE_M:
                return place.name
        if z < SURFACE_HEIGHT_TOLERANCE_M:
            return "floor"
        return None

    def get(self, name: str) -> KnownObject | None:
        with self._lock:
            return self._objects.get(name)

    def snapshot(self) -> tuple[KnownObject, ...]:
        with self._lock:
            return tuple(sorted(self._objects.values(), key=lambda k: k.name))

    def forget(self, name: str) -> None:
        with self._lock:
            self._objects.pop(name, None)

    def clear(self) -> None:
        with self._lock:
            self._objects.clear()
