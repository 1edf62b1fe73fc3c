"""A command as words that remember where they came from, so what the robot is asked to say keeps its own spelling.

Words are lower-cased, contractions opened ("what's" -> "what is", "don't" -> "do not", a possessive "room's" ->
"room"), hyphens inside a word split it ("living-room" -> "living room"); punctuation that can end a clause
(, ; : . ! ? and a dash between spaces) is kept as its own token, and a comma between two numbers ("1.2, 0.5") is
not, so a pose stays whole.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_TOKEN = re.compile(r"-?\d+(?:\.\d+)?|[a-z]+(?:'[a-z]+)*|[,;:.!?]|[-\u2013\u2014]+|[\"\u201c\u201d]")
_BREAKS = frozenset(",;:.!?")
_DASH = re.compile("[-\u2013\u2014]+")
_OPENED = {"n't": ("not",), "'m": ("am",), "'re": ("are",), "'ve": ("have",), "'ll": ("will",), "'d": ("would",)}
_IRREGULAR = {"can't": ("can", "not"), "won't": ("will", "not"), "let's": ("let", "us"), "y'all": ("you", "all")}
# 's after these is "is"; after anything else it marks a possessive ("the living room's table")
_DID_AFTER = frozenset(("where", "what", "how", "who", "why", "when"))
_IS_AFTER = frozenset(("it", "that", "what", "where", "there", "here", "who", "he", "she", "this", "how", "everything"))


@dataclass(frozen=True)
class Token:
    text: str  # a lower-case word, or a punctuation mark
    start: int  # where it stands in the raw command
    end: int

    @property
    def is_break(self) -> bool:
        """Punctuation that may end a clause."""
        return self.text in _BREAKS or _DASH.fullmatch(self.text) is not None


def tokenize(raw: str) -> list[Token]:
    text = raw.replace("\u2019", "'").replace("\u2018", "'").lower()
    tokens: list[Token] = []
    for match in _TOKEN.finditer(text):
        word, start, end = match.group(), match.start(), match.end()
        if _DASH.fullmatch(word) and not _standalone(text, start, end):
            continue  # a hyphen inside a word ("living-room") only separates its parts
        if word in ('"', "\u201c", "\u201d"):
            continue
        tokens.extend(Token(part, start, end) for part in _open(word))
    return _join_number_commas(tokens)


def _standalone(text: str, start: int, end: int) -> bool:
    return (start == 0 or text[start - 1].isspace()) and (end == len(text) or text[end].isspace())


def _open(word: str) -> tuple[str, ...]:
    if "'" not in word:
        return (word,)
    if word in _IRREGULAR:
        return _IRREGULAR[word]
    if word.endswith("'d") and word[:-2] in _DID_AFTER:  # "where'd it go": did
        return (word[:-2], "did")
    for ending, opened in _OPENED.items():
        if word.endswith(ending):
            stem = word[: -len(ending)]
            stem = {"ca": "can", "wo": "will", "sha": "shall"}.get(stem, stem)
            return (stem, *opened)
    if word.endswith("'s"):
        stem = word[:-2]
        return (stem, "is") if stem in _IS_AFTER else (stem,)
    return (word.replace("'", ""),)


def _is_number(token: Token) -> bool:
    return bool(re.fullmatch(r"-?\d+(?:\.\d+)?", token.text))


def _join_number_commas(tokens: list[Token]) -> list[Token]:
    """Drop a comma that stands between two numbers: "1.2, 0.5" is one pose, not two clauses."""
    kept = []
    for i, token in enumerate(tokens):
        between_numbers = 0 < i < len(tokens) - 1 and _is_number(tokens[i - 1]) and _is_number(tokens[i + 1])
        if token.text == "," and between_numbers:
            continue
        kept.append(token)
    return kept
