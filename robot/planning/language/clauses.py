"""A command cut into its steps, in the order they are to be done, without the words that ask nothing.

"First go to the kitchen, then find the mug" is two steps; so is "go to the dock after you say hello", in the
other order, and "before you go to the dock, look around". Politeness and fillers ("could you please", "hey
robot", "thanks") are cut from each step; a step that was nothing else disappears.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache

from robot.planning.language.lexicon import (
    CLAUSE_VERBS,
    DETERMINERS,
    FILLER_INFIXES,
    FILLER_PREFIXES,
    FILLER_SUFFIXES,
    SEQUENCE_WORDS,
    phrases,
    verbs,
)
from robot.planning.language.tokens import Token, tokenize


@dataclass(frozen=True)
class Clause:
    """Some words of the command, with the raw command they came from (what is to be said keeps its spelling)."""

    words: tuple[Token, ...]
    raw: str

    @property
    def text(self) -> str:
        return " ".join(t.text for t in self.words)

    def raw_of(self, start: int, end: int) -> str:
        """The raw command's text under the words that `self.text[start:end]` covers."""
        first, last = self._word_at(start), self._word_at(max(start, end - 1))
        return self.raw[self.words[first].start : self.words[last].end]

    def raw_start(self, start: int) -> int:
        return self.words[self._word_at(start)].start

    def _word_at(self, char: int) -> int:
        return self.text[:char].count(" ")

    def without_prefixes(self) -> Clause:
        """Without the politeness and fillers it starts with ("could you please", "hey robot, ")."""
        return self._cut(_prefix_pattern(), at_start=True)

    def without_suffixes(self) -> Clause:
        """Without the politeness it ends with ("thanks", "for me", "right now")."""
        return self._cut(_suffix_pattern(), at_start=False)

    def without_infixes(self) -> Clause:
        """Without the politeness said inside it ("bring the mug for me to the table")."""
        words = list(self.words)
        text = " ".join(t.text for t in words)
        for match in reversed(list(_infix_pattern().finditer(text))):
            first = text[: match.start()].count(" ")
            del words[first : first + len(match.group().split())]
        return Clause(tuple(words), self.raw)

    def _cut(self, pattern: re.Pattern[str], at_start: bool) -> Clause:
        words = list(self.words)
        while words:
            text = " ".join(t.text for t in words)
            match = pattern.search(text)
            if match is None or not match.group().strip():
                break
            count = len(match.group().split())
            words = words[count:] if at_start else words[:-count]
        return Clause(tuple(words), self.raw)


def split_command(raw: str) -> list[Clause]:
    """The command's steps, in the order they are to be done."""
    ordered: list[Clause] = []
    deferred: list[Clause] = []  # "before you go to the dock, look around": goes after the step that follows
    for segment in _segments(tokenize(raw), raw):
        for piece, order in _pieces(segment):
            if order == "after next":
                deferred.append(piece)
                continue
            if order == "before previous" and ordered:
                ordered.insert(len(ordered) - 1, piece)
            else:
                ordered.append(piece)
            ordered.extend(deferred)
            deferred.clear()
    return [*ordered, *deferred]


def _segments(tokens: list[Token], raw: str) -> list[Clause]:
    """Words between punctuation that can end a clause."""
    segments, current = [], []
    for token in tokens:
        if token.is_break:
            if current:
                segments.append(Clause(tuple(current), raw))
            current = []
        else:
            current.append(token)
    if current:
        segments.append(Clause(tuple(current), raw))
    return segments


# where a step goes, by the word that introduces it: "X after you Y" and "X, but first Y" do Y before X;
# "before you Y, X" does Y after X
_JOINT_ORDER = {"after": "before previous", "once": "before previous", "but first": "before previous"}
_LEAD_ORDER = {"before": "after next", "but first": "before previous"}


def _pieces(segment: Clause) -> list[tuple[Clause, str]]:
    """A segment cut where another step starts ("and then", "after you", "before"), each piece with where it
    goes: "now" (in the order said), "before previous" or "after next"."""
    words = segment.words
    pieces: list[tuple[Clause, str]] = []
    # politeness is not cut here, but no step starts inside it ("do me a favour and put ...")
    start = i = len(words) - len(segment.without_prefixes().words)
    order = "now"
    topic_end = _topic_before_pronoun_step(words, start)
    if topic_end is not None:  # "the apple put it on the table": the thing named first is a step of its own
        pieces.append((Clause(words[start:topic_end], segment.raw), order))
        start = i = topic_end
    while i < len(words):
        rest = " ".join(t.text for t in words[i:])
        found = (_lead() if i == start else _joint()).match(rest)
        if found and _step_follows(found, rest[found.end() :].strip()):
            kind = found.group("kind") or ""
            if i == start:
                order = _LEAD_ORDER.get(kind, order)
            else:
                pieces.append((Clause(words[start:i], segment.raw), order))
                order = _JOINT_ORDER.get(kind, "now")
            start = i = i + len(found.group().split())
            continue
        i += 1
    if start < len(words):
        pieces.append((Clause(words[start:], segment.raw), order))
    polite = words[: len(words) - len(segment.without_prefixes().words)]
    if not pieces:
        return [(segment, order)] if polite else []  # nothing but politeness: the reader skips it
    if polite:  # give the first piece back its politeness
        first, order = pieces[0]
        pieces[0] = (Clause((*polite, *first.words), segment.raw), order)
    return pieces


# a thing named before the step that says "it" of it is at most this many words ("the big red mug on the counter")
MAX_TOPIC_WORDS = 7
# a word before the verb that makes it the thing's own, or someone else's ("the man who picked it up", "the apple
# you put it on"): no step starts there
_VERB_NOT_A_STEP_AFTER = frozenset(
    {"who", "which", "that", "whoever", "whatever", "to", "and", "i", "you", "we", "they"}
)


def _topic_before_pronoun_step(words: tuple[Token, ...], start: int) -> int | None:
    """Where the step starts after a thing named first without a comma ("the apple put it on the table", "that
    bottle bring it here"): the words start with a determiner and a verb is followed by "it" or "them" a few
    words on. A typed command often has no comma there, and a recogniser seldom writes one."""
    if start >= len(words) or words[start].text not in DETERMINERS:
        return None
    for j in range(start + 2, min(start + MAX_TOPIC_WORDS, len(words) - 1) + 1):
        if words[j - 1].text in _VERB_NOT_A_STEP_AFTER:
            return None  # "the man who picked it up": the verb is the thing's own, no step
        if _pronoun_step().match(" ".join(t.text for t in words[j:])):
            return j
    return None


@cache
def _pronoun_step() -> re.Pattern[str]:
    return re.compile(rf"(?:{verbs(*CLAUSE_VERBS)}) (?:it|them)\b")


@cache
def _joint() -> re.Pattern[str]:
    """Words inside a segment that start another step ("and then", "after you", "before")."""
    return re.compile(
        rf"(?:{phrases(SEQUENCE_WORDS)}|(?P<kind>after|once|but first|before)(?: you)?(?: have)?(?: having)?)\b"
    )


@cache
def _lead() -> re.Pattern[str]:
    """Words a segment starts with that place it in time ("before you ...", "after you have ...")."""
    return re.compile(r"(?P<kind>before|after|once|when|but first)(?: you)?(?: have)?(?: having)?\b")


@cache
def _step_start() -> re.Pattern[str]:
    fillers = phrases(tuple(p for p in FILLER_PREFIXES if p not in ("and", "then", "first", "next", "so", "now")))
    return re.compile(rf"(?:{verbs(*CLAUSE_VERBS)}|{fillers}|when|once|after|before)\b")


def _starts_a_step(text: str) -> bool:
    return bool(text) and _step_start().match(text) is not None


def _step_follows(joint: re.Match[str], rest: str) -> bool:
    """Whether a step starts after these joining words. After "then" or "after that" one always does, even
    without its verb ("go to the table, then the dock"); after "and" or "after" only with one ("salt and
    pepper", "see you after lunch")."""
    if joint.group().split()[-1] in ("then", "afterwards", "finally", "lastly") or joint.group() == "after that":
        return bool(rest)
    return _starts_a_step(rest)


@cache
def _prefix_pattern() -> re.Pattern[str]:
    # "let's go" is "go", but "let us know that ..." is a message
    return re.compile(rf"^(?:{phrases(tuple(p for p in FILLER_PREFIXES if p != 'let us'))}|let us(?! know))(?: |$)")


@cache
def _infix_pattern() -> re.Pattern[str]:
    return re.compile(rf"(?<= ){phrases(FILLER_INFIXES)}(?= )")


@cache
def _suffix_pattern() -> re.Pattern[str]:
    return re.compile(rf"(?:^| ){phrases(FILLER_SUFFIXES)}$")
