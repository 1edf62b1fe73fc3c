"""What a planner and the validator may know about the world: named places and objects, and what is held."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from robot.interface import KnownObject
from robot.model.world import WorldLayout


def normalize(text: str) -> str:
    """Lower case, hyphens and punctuation to spaces, single spaces: 'Living-room table!' -> 'living room table'."""
    return " ".join(re.sub(r"[^a-z0-9 ]+", " ", text.lower()).split())


@dataclass(frozen=True)
class WorldContext:
    places: dict[str, tuple[str, ...]]  # canonical name -> aliases
    objects: dict[str, tuple[str, ...]]
    object_locations: dict[str, str]  # object -> place where it is believed to be
    held_object: str | None = None
    known_objects: tuple[KnownObject, ...] = ()  # what perception has seen, and where
    # how people may describe them: an object's colour and shape ("the red cup"), the room a place is in ("the
    # table in the living room"); empty when unknown
    object_colors: dict[str, str] = field(default_factory=dict)
    object_shapes: dict[str, str] = field(default_factory=dict)
    place_rooms: dict[str, str] = field(default_factory=dict)

    @staticmethod
    def from_layout(
        layout: WorldLayout, held_object: str | None = None, known_objects: tuple[KnownObject, ...] = ()
    ) -> WorldContext:
        """The world as the robot believes it: the layout's places and objects, where perception last saw each
        object overriding where the layout put it."""
        locations = {o.name: o.place for o in layout.objects}
        for known in known_objects:
            if known.place:
                locations[known.name] = known.place
        return WorldContext(
            places={p.name: p.aliases for p in layout.places},
            objects={o.name: o.aliases for o in layout.objects},
            object_locations=locations,
            held_object=held_object,
            known_objects=known_objects,
            object_colors={o.name: o.color for o in layout.objects},
            object_shapes={o.name: o.shape for o in layout.objects},
            place_rooms={p.name: p.room for p in layout.places},
        )

    def resolve_place(self, name: str) -> str | None:
        return _resolve(name, self.places)

    def resolve_object(self, name: str) -> str | None:
        return _resolve(name, self.objects)


def _resolve(name: str, table: dict[str, tuple[str, ...]]) -> str | None:
    wanted = normalize(name)
    for canonical, aliases in table.items():
        if wanted == normalize(canonical) or wanted in (normalize(a) for a in aliases):
            return canonical
    return None
