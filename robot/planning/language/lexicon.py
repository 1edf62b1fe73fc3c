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


def word_list(text: str) -> tuple[str, ...]:
    """Phrases separated by commas (a phrase may have spaces)."""
    return tuple(" ".join(p.split()) for p in text.split(",") if p.strip())


# --- actions -------------------------------------------------------------------------------------------------

PICK_VERBS = word_list("pick, grab, take, get, fetch, grasp, lift, collect, retrieve, snatch, nab")
CARRY_VERBS = word_list("""bring, take, carry, move, put, place, set, drop, leave, deliver, relocate, transport,
                        return, shift, stick, pop, lay""")
HAND_VERBS = word_list("bring, fetch, get, grab, hand, give, pass, take")
GO_VERBS = word_list("""go, navigate, walk, move, head, drive, return, come, proceed, travel, run, hurry, wander,
                     stroll, step, get""")
FIND_VERBS = word_list("find, locate, spot, detect, seek")
SAY_VERBS = word_list("say, speak, announce, shout, yell, declare, proclaim, broadcast")
TELL_VERBS = word_list("tell, inform, notify, remind, warn")
WAIT_VERBS = word_list("wait, pause, rest")
# what a clause may start with: "and" before one of these (or a filler) begins a new step
CLAUSE_VERBS = (
    *PICK_VERBS,
    *CARRY_VERBS,
    *GO_VERBS,
    *FIND_VERBS,
    *SAY_VERBS,
    *TELL_VERBS,
    *WAIT_VERBS,
    *word_list("""look, search, hunt, check, scan, stop, halt, freeze, let, make, have, stay, hold, stand,
                           describe, show, recharge, charge, dock, where, what"""),
)

# --- words that carry no request -----------------------------------------------------------------------------

# said before the request ("could you please", "hey robot", "I'd like you to")
FILLER_PREFIXES = word_list("""
    would you be so kind as to, would you be so kind and, would you be so kind to, will you be so kind as to,
    could you be so kind as to, be so kind as to, is there any chance you could, any chance you could,
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
    yo, oi, quick, hurry, hurry up, come on, excuse me, sorry, go on, yes, yeah, good morning, good afternoon,
    good evening, hello, greetings, i would appreciate it if you could, i would appreciate it if you would,
    i would appreciate if you could, i would be grateful if you could, it would be nice if you could,
    would it be possible to, would it be possible for you to, is it possible for you to, is it possible to,
    could the robot, help me, can you help me, could you help me, let us, i think, i guess, i suppose, pls,
    plz, about, what about, how about, no, i meant, i mean, mind, whoa, woah, oops, ah, oh no, off you go,
    on you go, it is time to, time to, now it is time to, it is time for you to,
    once done, when that is done, when finished""")
FILLER_SUFFIXES = word_list("""
    if you do not mind, when you get a chance, when you can, if you can, if you could, thank you very much,
    thanks a lot, thank you, thanks, cheers, please, for me, for us, right now, right away, immediately, at once,
    quickly, now, anyway, anyways, robot, buddy, mate, pal, would you, will you, could you, ok, okay, first, too,
    as well, and then, and, then, if possible, if you would, yeah, pls, plz, without stopping, without a stop,
    without pausing, without a break, non stop, nonstop, in one go, without stopping on the way,
    without stopping anywhere, do not stop, do not stop for anything, do not stop on the way, do not stop along the way,
    do not stop anywhere, and do not stop, no stopping, no stops, do not stop until you have it,
    do not stop until you get it, do not stop until you are done, do not stop until you get there,
    do not stop until you are there, and do not stop until you have it, and do not stop until you get it,
    and do not stop until you are done, never stop, never stop on the way, never stop along the way,
    never stop anywhere, never stop for anything, and never stop, and never stop on the way""")
# said anywhere in a request without changing it ("bring the mug for me to the table")
FILLER_INFIXES = word_list("please, for me, for us, kindly")
# what joins two steps said one after the other
SEQUENCE_WORDS = word_list("""and then, and after that, and afterwards, and finally, and next, and lastly, then,
                           after that, afterwards, next, finally, lastly, and, but then, but""")

# --- the things in the world ---------------------------------------------------------------------------------

# an object's shape -> what people call such a thing
OBJECT_WORDS: dict[str, tuple[str, ...]] = {
    "mug": word_list("""mug, cup, teacup, tea cup, coffee cup, coffee mug, tea mug, cup of coffee, cup of tea,
                     mug of coffee, mug of tea"""),
    "bottle": word_list("""bottle, water bottle, bottle of water, flask, drink bottle, drinks bottle, plastic bottle,
                        water"""),
    "apple": word_list("apple, fruit, piece of fruit"),
}
DRINK_SHAPES = ("mug", "bottle")  # what "something to drink" may be
DRINK_WORDS = word_list("drink, something to drink, beverage, something to drink from, something to drink out of")
# a place's kind (the last word of its name) -> what people call such a place
PLACE_WORDS: dict[str, tuple[str, ...]] = {
    "counter": word_list("counter, countertop, counter top, worktop, work top, work surface, kitchen bench"),
    "table": word_list("table, coffee table, dining table, side table, low table"),
    "dock": word_list("""dock, charger, charging dock, charging station, charging pad, charging mat, charging point,
                      charging spot, charging base, charging plate, docking station, dock station, base station,
                      recharging station, power station"""),
}
# a room -> its other names
ROOM_WORDS: dict[str, tuple[str, ...]] = {
    "kitchen": word_list("kitchen, kitchenette, kitchen area"),
    "living room": word_list("""living room, livingroom, living rooms, lounge, sitting room, family room, front room,
                             living area"""),
}
# rooms a house may have that this world does not: "the bedroom table" is no table here
OTHER_ROOMS = word_list("""bedroom, bathroom, garage, garden, office, hallway, hall, basement, attic, study,
                        dining room, porch, patio, balcony, toilet, laundry, cellar, yard, loft, nursery, corridor,
                        pantry, upstairs, downstairs, closet, utility room""")
COLOURS = word_list("red, green, blue, yellow, orange, purple, pink, black, white, brown, grey, gray")
GENERIC_NOUNS = word_list("one, thing, object, item, something")
DETERMINERS = word_list("the, a, an, my, your, our, his, her, their, this, that, these, those, some, any, its")
# words that describe without telling things apart in this world ("the dirty cup" is the cup)
PLAIN_ADJECTIVES = word_list("""little, small, big, large, nice, old, new, dirty, clean, empty, full, usual,
                             favourite, favorite, same, wooden, plastic, metal, tall""")
OBJECT_PRONOUNS = word_list("it, that, this, that one, this one, the object, them, the thing")
PLACE_PRONOUNS = word_list("there, that place, over there")

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
