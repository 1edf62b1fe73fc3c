"""The development set: the commands the understander is tuned on (the held-out set, `language_heldout`, is not).

Add a case here when a wording fails, never to the held-out set. Labels follow `language_cases`.
"""

from __future__ import annotations

from app.bench.language_cases import (
    APPLE,
    BOTTLE,
    CLARIFY,
    COUNTER,
    DOCK,
    HOME,
    LOOK,
    LOOK_AND_TELL,
    MUG,
    REFUSE,
    STOP,
    TABLE,
    LanguageCase,
    Seed,
    carry,
    fetch,
    find,
    go,
    say,
    seq,
    wait,
)


def _e(
    topic: str, text: str, expected: Seed, held: str | None = None, history: tuple[tuple[str, Seed], ...] = ()
) -> LanguageCase:
    return LanguageCase("everyday", topic, text, expected, held, history)


def _p(text: str, expected: Seed) -> LanguageCase:
    return LanguageCase("paraphrase", "readme", text, expected)


def _o(topic: str, text: str) -> LanguageCase:
    return LanguageCase("out_of_world", topic, text, REFUSE)


def _c(text: str) -> LanguageCase:
    return LanguageCase("clarify", "two readings", text, CLARIFY)


DEV: tuple[LanguageCase, ...] = (
    # politeness and fillers
    _e("polite", "please could you fetch me the mug", fetch(MUG)),
    _e("polite", "hey, grab me the cup would you", fetch(MUG)),
    _e("polite", "robot, I want you to get the bottle", fetch(BOTTLE)),
    _e("polite", "Would you be so kind as to bring me the apple?", fetch(APPLE)),
    _e("polite", "can you please go to the kitchen", go(COUNTER)),
    _e("polite", "uh, find the water bottle for me, thanks", find(BOTTLE)),
    _e("polite", "I'd love it if you brought me the green apple", fetch(APPLE)),
    _e("polite", "do me a favour and put the apple on the table", carry(APPLE, TABLE)),
    _e("polite", "could you possibly carry the cup to the dock?", carry(MUG, DOCK)),
    _e("polite", "Okay robot, go to the charging station now", go(DOCK)),
    _e("polite", "Please get me a cup", fetch(MUG)),
    _e("polite", "would you look for the bottle", find(BOTTLE)),
    _e("polite", "I need you to bring me the apple", fetch(APPLE)),
    _e("polite", "go ahead and pick up the teacup", fetch(MUG)),
    # a walk named by a noun
    _e("walk noun", "go for a walk to the table", go(TABLE)),
    _e("walk noun", "take a stroll to the dock", go(DOCK)),
    _e("walk noun", "have a walk over to the counter", go(COUNTER)),
    _e("walk noun", "make your way over to the charger", go(DOCK)),
    _e("walk noun", "wander over to the kitchen", go(COUNTER)),
    _e("walk noun", "take a trip to the living room", go(TABLE)),
    # a place described instead of named
    _e("place description", "walk to the counter in the kitchen", go(COUNTER)),
    _e("place description", "go to the living room's table", go(TABLE)),
    _e("place description", "bring the apple to the table that is in the living room", carry(APPLE, TABLE)),
    _e("place description", "head to the charging mat", go(DOCK)),
    _e("place description", "put the cup on the countertop", carry(MUG, COUNTER)),
    _e("place description", "take the bottle over to the lounge", carry(BOTTLE, TABLE)),
    _e("place description", "go to the docking station", go(DOCK)),
    # several steps in one sentence
    _e("sequence", "first find the apple, then go to the table", seq(find(APPLE), go(TABLE))),
    _e("sequence", "go to the table and then say hi", seq(go(TABLE), say("hi"))),
    _e("sequence", "say I am leaving, then go to the dock", seq(say("I am leaving"), go(DOCK))),
    _e("sequence", "look around and then go home", seq(LOOK, HOME)),
    _e("sequence", "after you find the mug, go back to the dock", seq(find(MUG), go(DOCK))),
    _e("sequence", "go home once you have said goodbye", seq(say("goodbye"), HOME)),
    _e("sequence", "go to the kitchen; then wait 5 seconds", seq(go(COUNTER), wait("5"))),
    _e(
        "sequence",
        "wait 2 seconds, then go to the counter, and finally say done",
        seq(wait("2"), go(COUNTER), say("done")),
    ),
    _e("sequence", "go to the kitchen and get the apple", fetch(APPLE)),
    _e("sequence", "bring the bottle to the table and then go home", seq(carry(BOTTLE, TABLE), HOME)),
    # a pronoun across two steps
    _e("pronoun", "grab the cup and put it on the dock", carry(MUG, DOCK)),
    _e("pronoun", "pick up the bottle then bring it here", fetch(BOTTLE)),
    _e("pronoun", "find the apple and bring it to me", seq(find(APPLE), fetch(APPLE))),
    _e("pronoun", "get the mug and set it down on the living room table", carry(MUG, TABLE)),
    _e("pronoun", "take the apple and move it to the charger", carry(APPLE, DOCK)),
    _e("pronoun", "pick up the red mug, then place it on the counter", carry(MUG, COUNTER)),
    # announcements, phrased any way
    _e("announcement", "announce dinner is ready", say("dinner is ready")),
    _e("announcement", "tell everybody the movie is starting", say("the movie is starting")),
    _e("announcement", "let them know that the door is open", say("the door is open")),
    _e("announcement", "please tell the team we won", say("we won")),
    _e("announcement", "make an announcement: the cake is in the oven", say("the cake is in the oven")),
    _e("announcement", "shout 'happy birthday'", say("happy birthday")),
    _e("announcement", "say to everyone: good night", say("good night")),
    _e("announcement", "could you let people know the taxi is outside", say("the taxi is outside")),
    _e("announcement", "tell them that I will be late", say("I will be late")),
    # the object first
    _e("object first", "the apple, put it on the table", carry(APPLE, TABLE)),
    _e("object first", "the water bottle - can you bring it to me", fetch(BOTTLE)),
    _e("object first", "that red cup, pick it up", fetch(MUG)),
    _e("object first", "the mug on the counter: take it to the dock", carry(MUG, DOCK)),
    _e("object first", "the green apple, where is it?", find(APPLE)),
    # near-miss names
    _e("near miss", "bring the red mud to the table", carry(MUG, TABLE)),
    _e("near miss", "put the apple on the kitchen counted", carry(APPLE, COUNTER)),
    _e("near miss", "go to the charging stashun", go(DOCK)),
    _e("near miss", "find the blue bottel", find(BOTTLE)),
    _e("near miss", "pick up the green appel", fetch(APPLE)),
    _e("near miss", "walk to the living rooms table", go(TABLE)),
    _e("near miss", "grab the read mug", fetch(MUG)),
    _e("near miss", "go to the charging doc", go(DOCK)),
    _e("near miss", "fetch the watter bottle", fetch(BOTTLE)),
    _e("near miss", "go to the livingroom table", go(TABLE)),
    # other words for the actions
    _e("action synonym", "collect the cup from the counter", fetch(MUG)),
    _e("action synonym", "hunt for the apple", find(APPLE)),
    _e("action synonym", "check where the bottle is", find(BOTTLE)),
    _e("action synonym", "tell me where the mug is", find(MUG)),
    _e("action synonym", "move over to the dock", go(DOCK)),
    _e("action synonym", "transport the bottle to the table", carry(BOTTLE, TABLE)),
    _e("action synonym", "stay still for 3 seconds", wait("3")),
    _e("action synonym", "wait a second", wait("1")),
    _e("action synonym", "scan your surroundings", LOOK),
    _e("action synonym", "what's around you?", LOOK_AND_TELL),
    _e("action synonym", "describe what you can see", LOOK_AND_TELL),
    _e("action synonym", "go back to your starting point", HOME),
    _e("action synonym", "go recharge", go(DOCK)),
    _e("stop", "stop now, robot", STOP),
    _e("stop", "please stop everything", STOP),
    _e("stop", "stop stop stop", STOP),
    _e("stop", "emergency stop!", STOP),
    # what is in hand, and what was said before
    _e("context", "bring it to me", fetch(BOTTLE), history=(("find the bottle", find(BOTTLE)),)),
    _e("context", "put it down on the counter", carry(BOTTLE, COUNTER, held=True), held=BOTTLE),
    _e("context", "then take it to the dock", carry(APPLE, DOCK, held=True), held=APPLE),
    # close paraphrases of the README's examples
    _p("pick up the red mug from the counter", fetch(MUG)),
    _p("please pick up the red mug from the kitchen counter", fetch(MUG)),
    _p("take the red mug to the living-room table", carry(MUG, TABLE)),
    _p("bring the red mug to the living room table please", carry(MUG, TABLE)),
    _p("go to the charging dock please", go(DOCK)),
    _p("head to the charging dock", go(DOCK)),
    _p("can you find the green apple?", find(APPLE)),
    _p("what do you see?", LOOK_AND_TELL),
    _p("what can you see around you", LOOK_AND_TELL),
    _p("go home please", HOME),
    _p("head back home", HOME),
    _p("wait 5 secs", wait("5")),
    _p("wait for five seconds", wait("5")),
    _p("stop please", STOP),
    _p("halt", STOP),
    _p("say hello there", say("hello there")),
    _p("say: hello", say("hello")),
    _p("bring me the green apple", fetch(APPLE)),
    _p("grab the red cup off the kitchen counter", fetch(MUG)),
    _p("head over to the kitchen counter", go(COUNTER)),
    _p("where is the blue bottle", find(BOTTLE)),
    _p("find the apple and then bring it to the table", seq(find(APPLE), carry(APPLE, TABLE))),
    _p("walk to (1.2, 0.5, 90 deg)", go("1.20, 0.50, 90 deg")),
    _p("look around the room", LOOK),
    # not in the world, or not an ability
    _o("unknown object", "bring me a beer"),
    _o("unknown object", "pick up the book"),
    _o("unknown object", "find my glasses"),
    _o("unknown object", "where are my keys"),
    _o("unknown object", "put the pillow on the sofa"),
    _o("unknown object", "bring the plate to the table"),
    _o("unknown place", "go to the garden"),
    _o("unknown place", "walk into the office"),
    _o("unknown place", "put the apple in the fridge"),
    _o("unknown place", "take the mug to the bathroom"),
    _o("unknown place", "go downstairs"),
    _o("unknown place", "go to the hallway"),
    _o("unknown ability", "jump"),
    _o("unknown ability", "sing a song"),
    _o("unknown ability", "do the dishes"),
    _o("unknown ability", "cook dinner"),
    _o("unknown ability", "fold the laundry"),
    _o("unknown ability", "open the window"),
    _o("unknown ability", "water the plants"),
    _o("unknown ability", "squeeze the apple"),
    _o("unknown ability", "drink from the mug"),
    _o("unknown ability", "smash the bottle"),
    _o("unknown ability", "tell me a joke"),
    _o("unknown ability", "what's the weather like today"),
    _o("unknown ability", "turn off the tv"),
    _o("unknown ability", "swim to the dock"),
    # two readings truly close
    _c("bring me the red bottle"),
    _c("walk to the table in the kitchen"),
    _c("get me a drink"),
    _c("grab the green mug"),
    _c("pick up the red apple"),
)
