"""The words people use for what the robot can do and for the things in its world, and the words that carry no
request (politeness, fillers).

Verbs are listed once, in their base form; `verbs()` adds every inflection (lemminflect's tables), so "would you
mind fetching", "if you brought me" and "once you have said goodbye" read like "fetch", "bring" and "say".
What the world's objects and places are called is the world's (`WorldContext`); here are only the everyday words
for their kinds (a mug is also a cup), colours and rooms, which hold in any seed's world.
"""

from __future__ import annotations

import re
from functools import cache


def _words(text: str) -> tuple[str, ...]:
    """Phrases separated by commas (a phrase may have spaces)."""
    return tuple(" ".join(p.split()) for p in text.split(",") if p.strip())


# --- actions -------------------------------------------------------------------------------------------------

PICK_VERBS = _words("pick, grab, take, get, fetch, grasp, lift, collect, retrieve, snatch, nab")
CARRY_VERBS = _words("""bring, take, carry, move, put, place, set, drop, leave, deliver, relocate, transport,
                        return, shift, stick, pop, lay""")
HAND_VERBS = _words("bring, fetch, get, grab, hand, give, pass, take")
GO_VERBS = _words("""go, navigate, walk, move, head, drive, return, come, proceed, travel, run, hurry, wander,
                     stroll, step, get""")
FIND_VERBS = _words("find, locate, spot, detect, seek")
SAY_VERBS = _words("say, speak, announce, shout, yell, declare, proclaim, broadcast")
TELL_VERBS = _words("tell, inform, notify, remind, warn")
WAIT_VERBS = _words("wait, pause, rest")
# what a clause may start with: "and" before one of these (or a filler) begins a new step
CLAUSE_VERBS = (
    *PICK_VERBS,
    *CARRY_VERBS,
    *GO_VERBS,
    *FIND_VERBS,
    *SAY_VERBS,
    *TELL_VERBS,
    *WAIT_VERBS,
    *_words("""look, search, hunt, check, scan, stop, halt, freeze, let, make, have, stay, hold, stand,
                           describe, show, recharge, charge, dock, where, what"""),
)

# --- words that carry no request -----------------------------------------------------------------------------

# said before the request ("could you please", "hey robot", "I'd like you to")
FILLER_PREFIXES = _words("""
    would you be so kind as to, would you be so kind and, is there any chance you could, any chance you could,
    do you think you could, i wonder if you could, i was wondering if you could, it would be great if you could,
    i would love it if you, i would like it if you, i would love you to, i would like you to, i want you to,
    i need you to, i am asking you to, if you do not mind, if you could, if you would, if you can,
    would you mind, do you mind, would you kindly, would you please, could you possibly, can you possibly,
    could you maybe, can you please, could you please, will you please, please could you, please can you,
    can you, could you, would you, will you, can u, you should, you need to, you could, you can, go ahead and,
    be a dear and, do me a favour and, do me a favor and, go and, try to, try and, hey robot, hi robot,
    hello robot, ok robot, okay robot, hey there, hi there, hello there, all right, alright, first of all,
    to begin with, to start with, please, kindly, robot, hey, hi, ok, okay, so, well, um, umm, uh, uhh, er, erm,
    hmm, oh, right, now, and, then, also, just, listen, quickly, possibly, maybe, first, firstly, next, finally,
    lastly, afterwards, after that, as for, regarding, when you are done, once you are done, when done,
    once done, when that is done, when finished""")
FILLER_SUFFIXES = _words("""
    if you do not mind, when you get a chance, when you can, if you can, if you could, thank you very much,
    thanks a lot, thank you, thanks, cheers, please, for me, for us, right now, right away, immediately, at once,
    quickly, now, robot, buddy, mate, pal, would you, will you, could you, ok, okay, first, too, as well, and then,
    and, then""")
# what joins two steps said one after the other
SEQUENCE_WORDS = _words("""and then, and after that, and afterwards, and finally, and next, and lastly, then,
                           after that, afterwards, next, finally, lastly, and""")

# --- the things in the world ---------------------------------------------------------------------------------

# an object's shape -> what people call such a thing
OBJECT_WORDS: dict[str, tuple[str, ...]] = {
    "mug": _words("""mug, cup, teacup, tea cup, coffee cup, coffee mug, tea mug, cup of coffee, cup of tea,
                     mug of coffee, mug of tea"""),
    "bottle": _words("""bottle, water bottle, bottle of water, flask, drink bottle, drinks bottle, plastic bottle,
                        water"""),
    "apple": _words("apple, fruit, piece of fruit"),
}
DRINK_SHAPES = ("mug", "bottle")  # what "something to drink" may be
DRINK_WORDS = _words("drink, something to drink, beverage, something to drink from, something to drink out of")
# a place's kind (the last word of its name) -> what people call such a place
PLACE_WORDS: dict[str, tuple[str, ...]] = {
    "counter": _words("counter, countertop, counter top, worktop, work top, work surface, kitchen bench"),
    "table": _words("table, coffee table, dining table, side table, low table"),
    "dock": _words("""dock, charger, charging dock, charging station, charging pad, charging mat, charging point,
                      charging spot, charging base, charging plate, docking station, dock station, base station,
                      recharging station, power station"""),
}
# a room -> its other names
ROOM_WORDS: dict[str, tuple[str, ...]] = {
    "kitchen": _words("kitchen, kitchenette, kitchen area"),
    "living room": _words("""living room, livingroom, living rooms, lounge, sitting room, family room, front room,
                             living area"""),
}
# rooms a house may have that this world does not: "the bedroom table" is no table here
OTHER_ROOMS = _words("""bedroom, bathroom, garage, garden, office, hallway, hall, basement, attic, study,
                        dining room, porch, patio, balcony, toilet, laundry, cellar, yard, loft, nursery, corridor,
                        pantry, upstairs, downstairs, closet, utility room""")
COLOURS = _words("red, green, blue, yellow, orange, purple, pink, black, white, brown, grey, gray")
GENERIC_NOUNS = _words("one, thing, object, item, something")
DETERMINERS = _words("the, a, an, my, your, our, his, her, their, this, that, these, those, some, any, its")
# words that describe without telling things apart in this world ("the dirty cup" is the cup)
PLAIN_ADJECTIVES = _words("""little, small, big, large, nice, old, new, dirty, clean, empty, full, usual,
                             favourite, favorite, same, wooden, plastic, metal, tall""")
OBJECT_PRONOUNS = _words("it, that, this, that one, this one, the object, them, the thing")
PLACE_PRONOUNS = _words("there, that place, over there")

# what `wait` understands, and what speech recognition listens for
NUMBER_WORDS = {
    "one": 1,
    "two": 2,
    "three": 3,
    "four": 4,
    "five": 5,
    "six": 6,
    "seven": 7,
    "eight": 8,
    "nine": 9,
    "ten": 10,
    "fifteen": 15,
    "twenty": 20,
    "thirty": 30,
    "a few": 3,
    "a couple of": 2,
}
# and what it understands besides ("wait a second", "wait forty seconds")
MORE_NUMBER_WORDS = {
    "a": 1,
    "an": 1,
    "a couple": 2,
    "eleven": 11,
    "twelve": 12,
    "forty": 40,
    "fifty": 50,
    "sixty": 60,
    "half a": 0.5,
}


@cache
def verbs(*bases: str) -> str:
    """A regex alternation of every form of these verbs: `verbs("bring")` matches bring, brings, brought,
    bringing."""
    from lemminflect import getAllInflections

    forms = set(bases)
    for base in bases:
        for inflected in getAllInflections(base, upos="VERB").values():
            forms.update(inflected)
    return phrases(tuple(forms))


def phrases(words: tuple[str, ...]) -> str:
    """A regex alternation of these phrases, longest first (so "pick up" is tried before "pick")."""
    return "(?:" + "|".join(re.escape(w) for w in sorted(words, key=len, reverse=True)) + ")"
