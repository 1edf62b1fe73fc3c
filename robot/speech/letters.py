"""Which script a heard wording is written in: the multilingual model sometimes drifts into another for a word."""

from __future__ import annotations

import unicodedata


def in_latin_script(text: str) -> bool:
    """No letter of another script: the multilingual model drifting into another language wrote "Walk to the
    counter,您 stop!" for "walk to the counter, then stop" (the fifteenth spoken set, stop 86)."""
    return all(not char.isalpha() or unicodedata.name(char, "").startswith("LATIN") for char in text)
