"""Which of the world's objects or places a phrase names: by a name or an alias, by an everyday word for its kind
("the cup", "the charger"), by its colour or room ("the red one", "the table in the living room"), or by a near
miss of a name (a recognition error: "the red mud", "the kitchen counted").

Strict where it matters: a phrase that names nothing in the world is an error that lists what is there, never a
guess; a near miss counts only when it is close to one name and clearly closer to it than to any other. When two
things fit a phrase about equally ("the blue mug": the red mug, or the blue bottle?), it asks which.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache

from rapidfuzz import fuzz
from rapidfuzz.distance import DamerauLevenshtein

from robot.planning.language.lexicon import (
    COLOURS,
    DETERMINERS,
    DRINK_SHAPES,
    DRINK_WORDS,
    GENERIC_NOUNS,
    OBJECT_WORDS,
    OTHER_ROOMS,
    PLACE_WORDS,
    PLAIN_ADJECTIVES,
    ROOM_WORDS,
    phrases,
)
from robot.planning.planner import ClarificationNeeded, PlanningError
from robot.planning.world_context import WorldContext, normalize

# A near miss counts from this similarity of the whole phrase (rapidfuzz's ratio, 0-100): "red mud" ~ "red mug" is
# 86, "kitchen counted" ~ "kitchen counter" 93; "jug" ~ "mug" (another object) is 67, "duck" ~ "dock" 75.
NEAR_MISS_MIN = 80.0
# ...each word that differs from the name's word in its place must be close to it ("mud" ~ "mug" 67, "stashun" ~
# "station" 57), not another word ("wine" ~ "water" 44: "the bottle of wine" is no bottle of water; "cab" ~ "cup" 33)
NEAR_MISS_WORD_MIN = 55.0
# ...a phrase with more or fewer words than the name must be closer ("livingroom table" ~ "living room table" 97)...
NEAR_MISS_REGROUPED_MIN = 88.0
# ...and it must be this much closer to one thing than to any other; else the two are too close to call
NEAR_MISS_MARGIN = 6.0
# ...and a word said alone must have this many letters: shorter ones are other words one slip away ("up" ~ "cup")
NEAR_MISS_MIN_LETTERS = 3

_LOCATION = re.compile(
    r"^(?P<head>.+?) (?:(?:that|which) is |is |that s |sitting |lying |standing |over |right |up |down )*"
    r"(?:in|on|at|from|off|by|near|inside|beside|next to|on top of|out of|off of) (?P<where>.+)$"
)
_DROPPED = frozenset((*DETERMINERS, *PLAIN_ADJECTIVES))


@dataclass(frozen=True)
class ObjectReference:
    name: str  # the object's canonical name
    source: str | None = None  # the place the phrase puts it at ("the mug on the counter"), if it says


class WorldNames:
    """The world's objects and places under every name people use for them."""

    def __init__(self, world: WorldContext, chosen: frozenset[str] = frozenset()) -> None:
        self.world = world
        self.chosen = chosen  # the operator's answers to earlier questions: among close readings, these win
        self._room_of_word = {w: room for room, words in ROOM_WORDS.items() for w in words}
        self._object_names = _object_table(
            tuple((o, a, world.object_colors.get(o), world.object_shapes.get(o)) for o, a in world.objects.items())
        )
        self._place_names = _place_table(tuple((p, a, world.place_rooms.get(p)) for p, a in world.places.items()))

    # --- objects ---------------------------------------------------------------------------------------------

    def object(self, phrase: str) -> ObjectReference:
        words = _clean(phrase)
        if not words:
            raise PlanningError(f"which object? known objects: {self.known_objects()}")
        if re.search(r"\b(?:and|or|both|all)\b", words) and words not in self._object_names:
            raise PlanningError(f"I can carry one thing at a time: name one of {self.known_objects()}")
        source = None
        located = _LOCATION.match(words) if words not in self._object_names else None
        if located:
            words, source = located.group("head"), self.place(located.group("where"))
        return ObjectReference(self._object_name(words, phrase), source)

    def _object_name(self, words: str, phrase: str) -> str:
        exact = self._object_names.get(words)
        if exact:
            return self._one(exact)
        if words in DRINK_WORDS:
            return self._one(self._objects_where(lambda o: self._shape(o) in DRINK_SHAPES))
        described = self._described_object(words)
        if described is not None:
            return described
        near = _near_miss(words, self._object_names) if not _words_before_its_article(phrase) else None
        if near is not None:
            return self._one(near)
        raise PlanningError(f"unknown object {_quoted(phrase)}; known objects: {self.known_objects()}")

    def _described_object(self, words: str) -> str | None:
        """ "the blue cup", "the green one": a kind and a colour, either of which may be left out."""
        tokens = words.split()
        colours = [w for w in tokens if w in COLOURS]
        noun = " ".join(w for w in tokens if w not in COLOURS)
        shape = next((s for s, names in OBJECT_WORDS.items() if noun in names), None)
        if not colours or (shape is None and noun not in GENERIC_NOUNS and noun):
            return None
        by_colour = self._objects_where(lambda o: self.world.object_colors.get(o) in colours)
        by_shape = self._objects_where(lambda o: self._shape(o) == shape) if shape else by_colour
        both = [o for o in by_shape if o in by_colour]
        if both:
            return self._one(both)
        if by_colour and by_shape:
            return self._one(by_shape + by_colour)
        known = self.known_objects()
        raise PlanningError(f"there is no {words} here; known objects: {known}")

    def _one(self, names: Iterable[str]) -> str:
        """The one thing these names come to (or the one the operator chose among them), else a question."""
        unique = list(dict.fromkeys(names))
        chosen = [n for n in unique if n in self.chosen]
        if len(unique) == 1 or len(chosen) == 1:
            return (chosen or unique)[0]
        raise _question(unique)

    def known_objects(self) -> str:
        return ", ".join(self.world.objects)

    def _shape(self, name: str) -> str | None:
        return self.world.object_shapes.get(name)

    def _objects_where(self, test) -> list[str]:  # type: ignore[no-untyped-def]
        return [o for o in self.world.objects if test(o)]

    # --- places ----------------------------------------------------------------------------------------------

    def place(self, phrase: str) -> str:
        words = _clean(phrase)
        if not words:
            raise PlanningError(f"which place? known places: {self.known_places()}")
        room = None
        located = _LOCATION.match(words) if words not in self._place_names else None
        if located:
            words, room = located.group("head"), self._room(located.group("where"), phrase)
        if room is not None:
            return self._place_in_room(words, room, phrase)
        exact = self._place_names.get(words)
        if exact:
            return self._one(exact)
        described = self._described_place(words, phrase)
        if described is not None:
            return described
        near = _near_miss(words, self._place_names) if not _words_before_its_article(phrase) else None
        if near is not None:
            return self._one(near)
        raise PlanningError(f"unknown place {_quoted(phrase)}; known places: {self.known_places()}")

    def _described_place(self, words: str, phrase: str) -> str | None:
        """ "the kitchen worktop", "the bedroom table": a kind of place and the room it is in."""
        other = re.search(rf"\b{phrases(OTHER_ROOMS)}\b", words)
        if other:
            raise PlanningError(f"unknown place {_quoted(phrase)}; known places: {self.known_places()}")
        found = re.search(rf"\b{phrases(tuple(self._room_of_word))}\b", words)
        if not found:
            return None
        noun = " ".join((words[: found.start()] + words[found.end() :]).split())
        return self._place_in_room(noun, self._room_of_word[found.group()], phrase) if noun else None

    def _place_in_room(self, noun: str, room: str, phrase: str) -> str:
        in_room = [p for p in self.world.places if self.world.place_rooms.get(p) == room]
        fitting = self._place_names.get(noun) or _near_miss(noun, self._place_names) or []
        if not fitting:
            kind = next((k for k, names in PLACE_WORDS.items() if noun in names), None)
            if kind is None:
                raise PlanningError(f"unknown place {_quoted(phrase)}; known places: {self.known_places()}")
        both = [p for p in fitting if p in in_room]
        if both:
            return self._one(both)
        if fitting and in_room:
            return self._one([*fitting, *in_room])
        raise PlanningError(f"there is no {noun} in the {room}; known places: {self.known_places()}")

    def _room(self, words: str, phrase: str) -> str:
        words = _clean(words)
        if words in self._room_of_word:
            return self._room_of_word[words]
        raise PlanningError(f"unknown place {_quoted(phrase)}; known places: {self.known_places()}")

    def known_places(self) -> str:
        return ", ".join(self.world.places)

    # --- either ----------------------------------------------------------------------------------------------

    def name_of(self, phrase: str) -> str | None:
        """The one object or place a phrase names, or None."""
        for look_up in (lambda: self.object(phrase).name, lambda: self.place(phrase)):
            try:
                return look_up()
            except PlanningError:
                continue
        return None

    def words(self) -> frozenset[str]:
        """Every word of every name the world's objects and places go by ("red", "mug", "kitchen", ...)."""
        return frozenset(w for table in (self._object_names, self._place_names) for said in table for w in said.split())

    def target(self, phrase: str) -> str:
        """Where to walk to: a place, or the place where an object is believed to be ("go to the mug")."""
        try:
            return self.place(phrase)
        except ClarificationNeeded:
            raise
        except PlanningError as not_a_place:
            try:
                reference = self.object(phrase)
            except ClarificationNeeded:
                raise
            except PlanningError:
                raise not_a_place from None
        where = reference.source or self.world.object_locations.get(reference.name)
        if where is None:
            raise PlanningError(f"I don't know where the {reference.name} is; say where to look, or ask me to find it")
        return where


# --- tables of names: built once per world, not per command --------------------------------------------------

ObjectSignature = tuple[tuple[str, tuple[str, ...], str | None, str | None], ...]  # name, aliases, colour, shape
PlaceSignature = tuple[tuple[str, tuple[str, ...], str | None], ...]  # name, aliases, room


@lru_cache(maxsize=16)
def _object_table(objects: ObjectSignature) -> dict[str, list[str]]:
    """Every way to call each object -> the objects so called."""
    table: dict[str, list[str]] = {}
    for name, aliases, colour, shape in objects:
        kind_words = OBJECT_WORDS.get(shape or "", ())
        said = [name, *aliases, *kind_words]
        if colour:
            said += [f"{colour} {w}" for w in (*kind_words, *GENERIC_NOUNS)]
        _add(table, said, name)
    return table


@lru_cache(maxsize=16)
def _place_table(places: PlaceSignature) -> dict[str, list[str]]:
    """Every way to call each place (its kind's everyday words, with or without its room) -> the places."""
    table: dict[str, list[str]] = {}
    for name, aliases, room in places:
        kind_words = PLACE_WORDS.get(normalize(name).split()[-1], ())
        room_words = ROOM_WORDS.get(room or "", ())
        said = [name, *aliases, *kind_words, *(f"{r} {w}" for r in room_words for w in kind_words)]
        if room is not None and normalize(room) in (normalize(a) for a in aliases):
            said += room_words  # the world calls the place by its room: so do the room's other names
        _add(table, said, name)
    return table


def _add(table: dict[str, list[str]], said: Iterable[str], name: str) -> None:
    for surface in said:
        names = table.setdefault(normalize(surface), [])
        if name not in names:
            names.append(name)


def _clean(phrase: str) -> str:
    """Lower case, no determiners, no adjectives that tell nothing apart and no pointing: "that little red cup
    over there" -> "red cup"."""
    words = " ".join(w for w in normalize(phrase).split() if w not in _DROPPED)
    return re.sub(r"(?<=\w) (?:over |right )?(?:there|here)$", "", words)


_ARTICLES = frozenset(("the", "a", "an"))


def _words_before_its_article(phrase: str) -> bool:
    """Whether words other than describing ones stand before the phrase's first article: "heat the mug", "feed
    the cup" (a verb the reader does not know, left in the phrase). A near miss of a name is a slip inside it ("the
    red mud"); with the unknown verb taken for a misheard colour, "heat the mug" (~ "tea mug") and "feed the cup"
    (~ "red cup") were fetches, though heating and feeding are no abilities."""
    words = normalize(phrase).split()
    first = next((i for i, word in enumerate(words) if word in _ARTICLES), 0)
    return any(word not in _DROPPED for word in words[:first])


def _near_miss(words: str, table: dict[str, list[str]]) -> list[str] | None:
    """The thing a misheard or mistyped phrase is closest to, when it is close to one thing only."""
    best: dict[str, float] = {}
    for surface, names in table.items():
        score = _likeness(words, surface)
        for name in names:
            best[name] = max(best.get(name, 0.0), score)
    ranked = sorted(best.items(), key=lambda item: item[1], reverse=True)
    if not ranked or ranked[0][1] < NEAR_MISS_MIN:
        return None
    close = [name for name, score in ranked if score >= NEAR_MISS_MIN and ranked[0][1] - score < NEAR_MISS_MARGIN]
    return close


def _likeness(words: str, surface: str) -> float:
    """How alike a phrase is to a name, 0-100, as a misheard or mistyped form of it (0 when a word is another
    word)."""
    score = fuzz.ratio(words, surface)
    said, named = words.split(), surface.split()
    if len(said) == len(named) == 1 and DamerauLevenshtein.distance(words, surface) > 1:
        return 0.0  # one word: one slip ("bottel", "aple"), not another word ("basket" is no "base")
    if len(said) == len(named) == 1 and len(words) < NEAR_MISS_MIN_LETTERS:
        return 0.0  # "up" is one slip from "cup", but a word of its own ("bring me up here" heard for "a beer")
    if len(said) != len(named):
        return score if score >= NEAR_MISS_REGROUPED_MIN else 0.0
    if any(a != b and fuzz.ratio(a, b) < NEAR_MISS_WORD_MIN for a, b in zip(said, named, strict=True)):
        return 0.0
    return score


QUESTION_START = "Did you mean"


def _question(names: Iterable[str]) -> ClarificationNeeded:
    options = tuple(dict.fromkeys(names))
    listed = " or ".join(f"the {n}" for n in options)
    return ClarificationNeeded(f"{QUESTION_START} {listed}?", options)


def _quoted(phrase: str) -> str:
    """The phrase as said, without its article: 'unknown object 'purple elephant''."""
    words = phrase.split()
    while len(words) > 1 and words[0].lower() in DETERMINERS:
        words = words[1:]
    return repr(" ".join(words))
