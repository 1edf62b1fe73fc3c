"""Spoken test sets for `humanoid bench speech` and the tests: what people say to the robot, in everyday wording,
with the plan each must give; stop phrases, alone and with a few words around them; and ordinary commands that
contain "stop" (which must not stop the robot).

Two sets, each with its own voices and speeds: `DEV`, the one the recognisers' hints, the confidence and the
stop spotter's thresholds are tuned on, and `HELDOUT`, written before any tuning (other voices, speeds and
phrasings) and only ever measured. Do not change a held-out case to make a figure pass; a wrong label may be
fixed, saying why in the commit.

Every case is asked in the default world (seed 0). Plans are labelled as in `planner_cases`; a sentence of
several steps as `seq` says (the steps' plans in order; a step's closing confirmation is left out when another
step follows; a step the same as the one just before it is left out).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.language_cases import LOOK
from harness.planner_cases import (
    APPLE,
    BOTTLE,
    COUNTER,
    DOCK,
    HOME,
    LOOK_AND_TELL,
    MUG,
    TABLE,
    Case,
    Seed,
    carry,
    fetch,
    find,
    go,
    seq,
)
from robot.speech.audio import RATE, Audio, add_noise
from robot.speech.tts import synthesize_audio


def say(text: str) -> Seed:
    return [{"action": "say", "text": text}]


def wait(seconds: str) -> Seed:
    return [{"action": "wait", "seconds": seconds}]


@dataclass(frozen=True)
class Voice:
    """An espeak-ng voice (with a variant after "+"), its speed in words per minute and its pitch (0-99)."""

    name: str
    wpm: int
    pitch: int = 50

    def label(self) -> str:
        return f"{self.name}@{self.wpm}"


@dataclass(frozen=True)
class SpokenSet:
    name: str
    voices: tuple[Voice, ...]
    commands: tuple[Case, ...]  # everyday wording, each with its plan
    stops: tuple[str, ...]  # an utterance that is a stop phrase, alone or with a few words: latches the e-stop
    with_stop: tuple[Case, ...]  # ordinary commands containing a stop word: no e-stop; plan as labelled
    # requests for what is not in the world or not an ability: no plan (added at stop 58, after the sets' commands
    # were measured; heldout2's were written then and only measured)
    out_of_world: tuple[str, ...] = ()


DEV = SpokenSet(
    name="dev",
    voices=(Voice("en-us", 160), Voice("en-gb", 175), Voice("en-us+f2", 140, 60), Voice("en-gb-x-rp", 150, 40)),
    commands=(
        # politeness and fillers
        Case("could you please bring me the red mug", fetch(MUG)),
        Case("hey robot, grab the apple for me", fetch(APPLE)),
        Case("um, go to the charging dock please", go(DOCK)),
        Case("would you mind picking up the water bottle", fetch(BOTTLE)),
        Case("okay robot, walk over to the kitchen counter", go(COUNTER)),
        Case("I would like the green apple please", fetch(APPLE)),
        Case("can you please find the mug for me", find(MUG)),
        Case("so, uh, what do you see right now", LOOK_AND_TELL),
        # everyday words for the things and places
        Case("fetch the coffee cup", fetch(MUG)),
        Case("go to the charger", go(DOCK)),
        Case("put the bottle on the coffee table", carry(BOTTLE, TABLE)),
        Case("head to the kitchen", go(COUNTER)),
        Case("bring the fruit to the table", carry(APPLE, TABLE)),
        Case("where did the water bottle go", find(BOTTLE)),
        # sequences
        Case("pick up the apple and then bring it to the table", carry(APPLE, TABLE)),
        Case("go to the dock and then come back home", seq(go(DOCK), HOME)),
        Case("first find the bottle, then pick it up", seq(find(BOTTLE), fetch(BOTTLE))),
        Case("walk to the table and tell me what you see", seq(go(TABLE), LOOK_AND_TELL)),
        # pronouns: what the robot holds, what was just talked about
        Case("put it on the table", carry(MUG, TABLE, held=True), held=MUG),
        Case("now bring it to me", fetch(APPLE), history=(("find the apple", find(APPLE)),)),
        # the object first
        Case("the red mug, bring it to the table", carry(MUG, TABLE)),
        # announcements, waiting, home
        Case("say good morning everyone", say("good morning everyone")),
        Case("wait for five seconds", wait("5")),
        Case("go back to where you started", HOME),
        Case("head home please", HOME),
        Case("take the mug to the living room", carry(MUG, TABLE)),
        Case("could you carry the apple to the charging dock", carry(APPLE, DOCK)),
        Case("look for the green apple", find(APPLE)),
    ),
    stops=(
        "stop",
        "halt",
        "freeze",
        "robot stop",
        "emergency stop",
        "stop now",
        "stop right now",
        "please stop",
        "halt please",
        "freeze right now",
        "robot, stop please",
        "emergency stop now",
    ),
    with_stop=(
        Case("go to the dock and stop there", go(DOCK)),
        Case("stop by the kitchen and get the mug", fetch(MUG)),
        Case("don't stop until you reach the table", go(TABLE)),
        Case("walk to the table without stopping", go(TABLE)),
    ),
    out_of_world=(
        "bring me a beer",
        "pick up the book",
        "go to the garden",
        "walk into the office",
        "sing a song",
        "open the window",
        "tell me a joke",
        "put the apple in the fridge",
    ),
)

HELDOUT = SpokenSet(
    name="heldout",
    voices=(
        Voice("en-gb-scotland+m3", 150, 45),
        Voice("en-029", 165),
        Voice("en-us-nyc+f4", 185, 55),
        Voice("en-gb-x-gbclan+m6", 130),
    ),
    commands=(
        Case("would you be so kind as to fetch the bottle", fetch(BOTTLE)),
        Case("robot, please take the mug to the living room table", carry(MUG, TABLE)),
        Case("er, could you head over to the charging station", go(DOCK)),
        Case("I need the apple, thanks", fetch(APPLE)),
        Case("please grab me the water bottle", fetch(BOTTLE)),
        Case("what can you see from where you are", LOOK_AND_TELL),
        Case("could you carry the apple over to the dock", carry(APPLE, DOCK)),
        Case("take the cup and put it on the counter", carry(MUG, COUNTER)),
        Case("walk to the kitchen, then go to the dock", seq(go(COUNTER), go(DOCK))),
        Case("grab the bottle and bring it to me", fetch(BOTTLE)),
        Case("set it down on the coffee table", carry(APPLE, TABLE, held=True), held=APPLE),
        Case("okay, pick that up", fetch(BOTTLE), history=(("where is the bottle", find(BOTTLE)),)),
        Case("the green apple, could you bring it to the table", carry(APPLE, TABLE)),
        Case("say welcome home", say("welcome home")),
        Case("pause for three seconds", wait("3")),
        Case("return to your start position", HOME),
        Case("drive over to the counter", go(COUNTER)),
        Case("hey, where is my mug", find(MUG)),
        Case("please search for the bottle", find(BOTTLE)),
        Case("first go to the table, then come back home", seq(go(TABLE), HOME)),
        Case("can you move to the charger", go(DOCK)),
        Case("pick up the cup please", fetch(MUG)),
        Case("please bring the apple over here", fetch(APPLE)),
        Case("describe what you see", LOOK_AND_TELL),
        Case("go home now", HOME),
        Case("uh, bring me something to drink, the bottle", fetch(BOTTLE)),
        Case("could you get the mug off the counter for me", fetch(MUG)),
        Case("make your way over to the dock", go(DOCK)),
    ),
    stops=(
        "stop!",
        "stop please",
        "halt now",
        "freeze please",
        "robot stop now",
        "emergency stop please",
        "hey robot, stop",
        "okay stop",
        "halt right now",
        "freeze",
        "emergency stop",
        "robot, halt",
    ),
    with_stop=(
        Case("drive to the counter and stop next to it", go(COUNTER)),
        Case("stop at the counter and pick up the apple", fetch(APPLE)),
        # (relabelled at stop 57: was the carry then a "stop" step; the planner reads a stop after the last motion
        # as where that motion ends, and a plan has the robot standing still at its end anyway)
        Case("bring the mug to the table and then stop moving", carry(MUG, TABLE)),
        Case("go to the charging dock and stop when you get there", go(DOCK)),
    ),
    out_of_world=(
        "bring me the banana",
        "pick up my phone",
        "go to the bedroom",
        "take the apple to the garage",
        "do a backflip",
        "make me a cup of coffee",
        "wash the red mug",
        "play some music",
    ),
)

# Written on 2026-11-28 (stop 57) before the planner and the recogniser's hints were changed with `HELDOUT`'s
# failures in view: from then on `HELDOUT` is one more set tuned on, and this one is only measured.
HELDOUT2 = SpokenSet(
    name="heldout2",
    voices=(
        Voice("en-gb-x-gbcwmd+m1", 160),
        Voice("en-us+m7", 145, 35),
        Voice("en-gb-x-rp+f4", 185, 60),
        Voice("en-029+f3", 150, 55),
    ),
    commands=(
        Case("hi robot, can you get me the apple", fetch(APPLE)),
        Case("I'd love a drink, grab the water bottle please", fetch(BOTTLE)),
        Case("please go over to the kitchen counter", go(COUNTER)),
        Case("could you bring the red mug over to the dock", carry(MUG, DOCK)),
        Case("take the bottle to the kitchen", carry(BOTTLE, COUNTER)),
        Case("find the red cup", find(MUG)),
        Case("look around and tell me what's there", LOOK_AND_TELL),
        Case("where's the apple", find(APPLE)),
        Case("go to your charging station", go(DOCK)),
        Case("move the apple onto the living room table", carry(APPLE, TABLE)),
        Case("pick up the mug, then take it to the dock", carry(MUG, DOCK)),
        Case("go to the counter and then to the table", seq(go(COUNTER), go(TABLE))),
        Case("first look around, then go home", seq(LOOK_AND_TELL, HOME)),
        Case("place it on the kitchen counter", carry(MUG, COUNTER, held=True), held=MUG),
        Case("bring that to me", fetch(BOTTLE), history=(("find the water bottle", find(BOTTLE)),)),
        Case("the water bottle, put it on the table please", carry(BOTTLE, TABLE)),
        Case("announce that dinner is ready", say("dinner is ready")),
        Case("tell everyone hello", say("hello")),
        Case("hold on for ten seconds", wait("10")),
        Case("just wait two seconds", wait("2")),
        Case("go back to your starting point", HOME),
        Case("come back home please", HOME),
        Case("walk over to the living room", go(TABLE)),
        Case("can you fetch me the green apple from the counter", fetch(APPLE)),
        Case("would you kindly put the mug on the living room table", carry(MUG, TABLE)),
        Case("search the room for the apple", find(APPLE)),
        Case("have a look around and describe it", LOOK_AND_TELL),
        Case("okay now head over to the dock", go(DOCK)),
    ),
    stops=(
        "stop right now please",
        "please halt",
        "robot freeze",
        "okay robot, stop",
        "emergency stop, now",
        "hey stop",
        "halt",
        "freeze now please",
        "stop stop",
        "robot stop please",
        "please freeze",
        "emergency stop right now",
    ),
    with_stop=(
        Case("go to the table and stop in front of it", go(TABLE)),
        Case("walk to the counter, then stop", go(COUNTER)),  # (as in HELDOUT: the stop is where the walk ends)
        Case("fetch the apple and don't stop for anything", fetch(APPLE)),
        Case("head to the charger and stop beside it", go(DOCK)),
    ),
    out_of_world=(
        "fetch my slippers",
        "grab the remote",
        "go out to the garden shed",
        "put the bottle in the sink",
        "feed the cat",
        "turn on the television",
        "clean the kitchen floor",
        "climb onto the table",
    ),
)

# Written on 2026-11-28 (stop 59), after `HELDOUT2`'s figures had been read (its misses seen, so from then on it is
# one more set looked at) and before any of these was spoken: other voices, speeds and wordings; only measured.
HELDOUT3 = SpokenSet(
    name="heldout3",
    voices=(
        Voice("en-us+edward", 155),
        Voice("en-gb-scotland+f5", 170, 65),
        Voice("en-gb+m4", 140, 40),
        Voice("en-us-nyc+m2", 175, 50),
    ),
    commands=(
        Case("could you grab me the bottle of water", fetch(BOTTLE)),
        Case("I need the green apple, please bring it over", fetch(APPLE)),
        Case("head to the kitchen", go(COUNTER)),
        Case("go and stand by the charging dock", go(DOCK)),
        Case("carry the apple to the table", carry(APPLE, TABLE)),
        Case("put the red mug on the counter", carry(MUG, COUNTER)),
        Case("can you find my mug", find(MUG)),
        Case("where did I leave the water bottle", find(BOTTLE)),
        Case("what do you see around you", LOOK_AND_TELL),
        Case("take a look around the room", LOOK),
        Case("please return to where you started", HOME),
        Case("time to go home now", HOME),
        Case("walk over to the table in the living room", go(TABLE)),
        Case("get the apple and put it on the living room table", carry(APPLE, TABLE)),
        Case("pick up the bottle and bring it to the dock", carry(BOTTLE, DOCK)),
        Case("first go to the dock, then come back to the counter", seq(go(DOCK), go(COUNTER))),
        Case("say good morning", say("good morning")),
        Case("tell them the robot is ready", say("the robot is ready")),
        Case("wait five seconds", wait("5")),
        Case("pause for three seconds please", wait("3")),
        Case("hey robot, fetch the red mug for me", fetch(MUG)),
        Case("I'm thirsty, could you get me the water bottle", fetch(BOTTLE)),
        Case("leave it at the charging dock", carry(APPLE, DOCK, held=True), held=APPLE),
        Case("bring it here", fetch(APPLE), history=(("find the green apple", find(APPLE)),)),
        Case("the red mug, take it to the kitchen counter", carry(MUG, COUNTER)),
        Case("would you mind looking for the apple", find(APPLE)),
        Case("kindly move over to the dock", go(DOCK)),
        Case("look around, then bring me the mug", seq(LOOK, fetch(MUG))),
    ),
    stops=(
        "stop",
        "stop it",
        "halt now",
        "freeze please",
        "robot, stop now",
        "hey robot stop",
        "emergency stop please",
        "okay stop",
        "stop please",
        "please stop now",
        "robot halt",
        "no no, stop",
    ),
    with_stop=(
        Case("go to the charging dock and stop when you get there", go(DOCK)),
        Case("drive up to the counter and stop next to it", go(COUNTER)),
        Case("bring me the apple without stopping", fetch(APPLE)),
        Case("fetch the bottle, don't stop on the way", fetch(BOTTLE)),
    ),
    out_of_world=(
        "bring me my phone",
        "go upstairs to the bedroom",
        "open the fridge",
        "make me a sandwich",
        "put the mug in the dishwasher",
        "fold the laundry",
        "call my mother",
        "sing a song",
    ),
)

# A fifth set, written at stop 60 before any engine heard it, to compare whisper's tiny.en with the multilingual base
# model on sentences and voices neither was chosen on: four more espeak-ng voices, new wordings.
HELDOUT4 = SpokenSet(
    name="heldout4",
    voices=(
        Voice("en-us+david", 150),
        Voice("en-gb-x-rp+f1", 165, 60),
        Voice("en-029+m5", 155, 45),
        Voice("en-us+annie", 170, 55),
    ),
    commands=(
        Case("could you fetch the green apple for me", fetch(APPLE)),
        Case("go over to the kitchen counter please", go(COUNTER)),
        Case("I'd like the blue bottle", fetch(BOTTLE)),
        Case("move the mug to the living room table", carry(MUG, TABLE)),
        Case("please go to your charging dock", go(DOCK)),
        Case("find the red mug", find(MUG)),
        Case("look for the blue bottle", find(BOTTLE)),
        Case("have a look around", LOOK),
        Case("tell me what you can see", LOOK_AND_TELL),
        Case("go back to where you began", HOME),
        Case("head back home", HOME),
        Case("take the apple over to the dock", carry(APPLE, DOCK)),
        Case("bring the bottle to the kitchen counter", carry(BOTTLE, COUNTER)),
        Case("grab the mug and leave it on the table", carry(MUG, TABLE)),
        Case("go to the table and then to the dock", seq(go(TABLE), go(DOCK))),
        Case("say hello everyone", say("hello everyone")),
        Case("announce that dinner is ready", say("dinner is ready")),
        Case("wait for ten seconds", wait("10")),
        Case("hold on for two seconds", wait("2")),
        Case("robot, please get me the red mug", fetch(MUG)),
        Case("I'm hungry, bring me the apple", fetch(APPLE)),
        Case("put it down on the counter", carry(BOTTLE, COUNTER, held=True), held=BOTTLE),
        Case("bring it to me", fetch(BOTTLE), history=(("find the blue bottle", find(BOTTLE)),)),
        Case("the apple, put it on the counter", carry(APPLE, COUNTER)),
        Case("would you please walk to the living room", go(TABLE)),
        Case("can you search for the green apple", find(APPLE)),
        Case("drive over to the charger", go(DOCK)),
        Case("look around first, then fetch the bottle", seq(LOOK, fetch(BOTTLE))),
    ),
    stops=(
        "stop right there",
        "stop the robot",
        "halt",
        "freeze right now",
        "stop stop",
        "robot stop please",
        "hey, stop",
        "please halt",
        "stop moving",
        "emergency stop",
        "okay robot, freeze",
        "wait, stop",
    ),
    with_stop=(
        Case("go to the counter and stop there", go(COUNTER)),
        Case("walk to the table but stop in front of it", go(TABLE)),
        Case("fetch the mug and don't stop until you have it", fetch(MUG)),
        Case("bring me the apple and then stop", fetch(APPLE)),
    ),
    out_of_world=(
        "bring me the remote control",
        "go to the garage",
        "wash the dishes",
        "turn on the television",
        "take out the trash",
        "fly up to the roof",
        "play some music",
        "order a pizza",
    ),
)

# A sixth set, written at stop 79 (2026-12-01) before any engine heard it: four more espeak-ng voices and wordings
# not in the sets above; only measured.
HELDOUT5 = SpokenSet(
    name="heldout5",
    voices=(
        Voice("en-us+paul", 160),
        Voice("en-gb-x-gbclan+f2", 150, 60),
        Voice("en-gb-x-gbcwmd+robert", 170, 45),
        Voice("en-us+linda", 145, 55),
    ),
    commands=(
        Case("can I have the red mug please", fetch(MUG)),
        Case("fetch me that bottle of water", fetch(BOTTLE)),
        Case("get over to the counter", go(COUNTER)),
        Case("go to the living room table", go(TABLE)),
        Case("could you walk to the dock please", go(DOCK)),
        Case("please bring the apple to the kitchen counter", carry(APPLE, COUNTER)),
        Case("take the water bottle to the table", carry(BOTTLE, TABLE)),
        Case("put the mug by the charging dock", carry(MUG, DOCK)),
        Case("where is the green apple", find(APPLE)),
        Case("try to find the red mug", find(MUG)),
        Case("look all around you", LOOK),
        Case("what can you see right now", LOOK_AND_TELL),
        Case("go back to your starting point", HOME),
        Case("return home please", HOME),
        Case("pick up the apple and take it to the dock", carry(APPLE, DOCK)),
        Case("go to the counter, then go to the table", seq(go(COUNTER), go(TABLE))),
        Case("say welcome home", say("welcome home")),
        Case("tell everyone that lunch is ready", say("lunch is ready")),
        Case("wait four seconds", wait("4")),
        Case("hang on, wait thirty seconds", wait("30")),
        Case("hey robot, could you grab the green apple", fetch(APPLE)),
        Case("I want some water, bring me the bottle", fetch(BOTTLE)),
        Case("set it down on the table", carry(MUG, TABLE, held=True), held=MUG),
        Case("now bring it over here", fetch(MUG), history=(("look for the red mug", find(MUG)),)),
        Case("the water bottle, bring it to the counter", carry(BOTTLE, COUNTER)),
        Case("would you go over to the kitchen", go(COUNTER)),
        Case("please look for my bottle", find(BOTTLE)),
        Case("have a look around and then go to the dock", seq(LOOK, go(DOCK))),
    ),
    stops=(
        "stop",
        "stop now",
        "halt please",
        "freeze",
        "robot stop",
        "stop right now",
        "emergency stop now",
        "hey stop",
        "oh no, stop",
        "please freeze",
        "robot, halt",
        "stop, stop",
    ),
    with_stop=(
        Case("walk to the dock and stop beside it", go(DOCK)),
        Case("go to the table and stop there please", go(TABLE)),
        Case("bring me the bottle and don't stop", fetch(BOTTLE)),
        Case("fetch the red mug without stopping on the way", fetch(MUG)),
    ),
    out_of_world=(
        "bring me my keys",
        "go down to the basement",
        "open the window",
        "water the plants",
        "put the apple in the fridge",
        "iron my shirt",
        "text my brother",
        "dance for me",
    ),
)

# A seventh set, written at stop 79 after `HELDOUT5`'s misses were read (and fixed where a general rule covered them)
# and before any engine heard this one: to measure those fixes on voices and wordings they were not made on.
HELDOUT6 = SpokenSet(
    name="heldout6",
    voices=(
        Voice("en-us+mike", 165),
        Voice("en-gb+f3", 155, 60),
        Voice("en-gb-x-rp+steph", 150, 55),
        Voice("en-us-nyc+john", 170, 45),
    ),
    commands=(
        Case("would you bring me the green apple", fetch(APPLE)),
        Case("go get the blue bottle for me", fetch(BOTTLE)),
        Case("make your way to the kitchen counter", go(COUNTER)),
        Case("walk over to the table", go(TABLE)),
        Case("head over to the charger please", go(DOCK)),
        Case("bring the red mug over to the table", carry(MUG, TABLE)),
        Case("carry the bottle to the charging dock", carry(BOTTLE, DOCK)),
        Case("place the apple on the living room table", carry(APPLE, TABLE)),
        Case("can you tell me where the mug is", find(MUG)),
        Case("search the room for the water bottle", find(BOTTLE)),
        Case("look around the room", LOOK),
        Case("describe what you see", LOOK_AND_TELL),
        Case("go back to the start", HOME),
        Case("come back home", HOME),
        Case("grab the bottle and put it on the table", carry(BOTTLE, TABLE)),
        Case("go to the dock and then come to the counter", seq(go(DOCK), go(COUNTER))),
        Case("say thank you", say("thank you")),
        Case("announce that the room is clean", say("the room is clean")),
        Case("wait two seconds", wait("2")),
        Case("stay there for five seconds", wait("5")),
        Case("excuse me robot, bring me the mug", fetch(MUG)),
        Case("I would like the apple please", fetch(APPLE)),
        Case("drop it off at the counter", carry(APPLE, COUNTER, held=True), held=APPLE),
        Case("bring it to me please", fetch(BOTTLE), history=(("look for the blue bottle", find(BOTTLE)),)),
        Case("the green apple, put it on the table", carry(APPLE, TABLE)),
        Case("please walk to the kitchen", go(COUNTER)),
        Case("can you look for the red mug", find(MUG)),
        Case("look around, then go home", seq(LOOK, HOME)),
    ),
    stops=(
        "stop",
        "stop please",
        "halt right now",
        "freeze now",
        "robot, stop",
        "hey robot, halt",
        "emergency stop",
        "okay, stop now",
        "no, stop",
        "stop it now",
        "please freeze",
        "stop the robot now",
    ),
    with_stop=(
        Case("go to the counter and stop next to it", go(COUNTER)),
        Case("walk to the dock and stop when you get there", go(DOCK)),
        Case("bring me the mug, do not stop", fetch(MUG)),
        Case("fetch the apple and never stop on the way", fetch(APPLE)),
    ),
    out_of_world=(
        "bring me my glasses",
        "go to the bathroom",
        "close the door",
        "feed the dog",
        "put the bottle in the oven",
        "vacuum the carpet",
        "email my boss",
        "jump up and down",
    ),
)

# An eighth set, written at stop 79 after `HELDOUT6`'s misses were read (its stop misses turned into a rule) and before
# any engine heard this one: those rules measured on voices and wordings they were not made on.
HELDOUT7 = SpokenSet(
    name="heldout7",
    voices=(
        Voice("en-us+max", 155),
        Voice("en-gb-scotland+anika", 165, 60),
        Voice("en-gb-x-gbcwmd+zac", 150, 45),
        Voice("en-us+shelby", 170, 55),
    ),
    commands=(
        Case("please fetch the blue bottle", fetch(BOTTLE)),
        Case("could I get the red mug", fetch(MUG)),
        Case("go stand by the counter", go(COUNTER)),
        Case("walk to the living room", go(TABLE)),
        Case("go dock yourself", go(DOCK)),
        Case("move the apple to the counter", carry(APPLE, COUNTER)),
        Case("bring the mug to the charger", carry(MUG, DOCK)),
        Case("leave the bottle on the table", carry(BOTTLE, TABLE)),
        Case("do you know where the apple is", find(APPLE)),
        Case("locate the blue bottle", find(BOTTLE)),
        Case("look about the room", LOOK),
        Case("tell me what is around you", LOOK_AND_TELL),
        Case("return to your starting position", HOME),
        Case("go home please", HOME),
        Case("take the mug and put it by the dock", carry(MUG, DOCK)),
        Case("first go to the table, then go to the counter", seq(go(TABLE), go(COUNTER))),
        Case("say good night", say("good night")),
        Case("announce that the robot is charging", say("the robot is charging")),
        Case("wait six seconds", wait("6")),
        Case("hold still for three seconds", wait("3")),
        Case("hello robot, please get me the apple", fetch(APPLE)),
        Case("I'm thirsty, get me the bottle", fetch(BOTTLE)),
        Case("put it on the counter please", carry(MUG, COUNTER, held=True), held=MUG),
        Case("bring it to me", fetch(APPLE), history=(("where is the green apple", find(APPLE)),)),
        Case("the red mug, bring it to the table", carry(MUG, TABLE)),
        Case("go over to the kitchen please", go(COUNTER)),
        Case("look for the green apple", find(APPLE)),
        Case("look around and then fetch the mug", seq(LOOK, fetch(MUG))),
    ),
    stops=(
        "stop",
        "stop now please",
        "halt",
        "freeze right now",
        "robot, stop now",
        "hey, halt",
        "emergency stop right now",
        "okay robot, stop",
        "stop, stop, stop",
        "please stop it",
        "freeze, robot",
        "stop the robot please",
    ),
    with_stop=(
        Case("go to the table and stop in front of it", go(TABLE)),
        Case("walk to the counter and stop there", go(COUNTER)),
        Case("get me the apple and do not stop", fetch(APPLE)),
        Case("bring the bottle over without stopping", fetch(BOTTLE)),
    ),
    out_of_world=(
        "bring me a towel",
        "go to the bedroom",
        "turn off the lights",
        "walk the dog",
        "put the mug in the microwave",
        "make the bed",
        "call a taxi",
        "do a backflip",
    ),
)

# A ninth set, written at stop 80 before any engine heard it and before `HELDOUT7`'s stop misses were read: what the
# changes of stop 80 do, measured on voices and wordings they were not made on.
HELDOUT8 = SpokenSet(
    name="heldout8",
    voices=(
        Voice("en-us+benjamin", 160),
        Voice("en-gb-x-gbclan+belinda", 155, 60),
        Voice("en-029+aunty", 165, 55),
        Voice("en-us-nyc+caleb", 150, 45),
    ),
    commands=(
        Case("can you fetch me the red mug", fetch(MUG)),
        Case("I need the water bottle, bring it here", fetch(BOTTLE)),
        Case("walk up to the kitchen counter", go(COUNTER)),
        Case("go to the coffee table", go(TABLE)),
        Case("go and charge yourself", go(DOCK)),
        Case("take the green apple to the dock", carry(APPLE, DOCK)),
        Case("put the mug on the kitchen counter", carry(MUG, COUNTER)),
        Case("set the bottle down on the table", carry(BOTTLE, TABLE)),
        Case("where is the red mug", find(MUG)),
        Case("find me the apple", find(APPLE)),
        Case("have a look around", LOOK),
        Case("what can you see", LOOK_AND_TELL),
        Case("go back to where you started", HOME),
        Case("return home", HOME),
        Case("pick up the apple and take it to the table", carry(APPLE, TABLE)),
        Case("go to the counter, then go to the dock", seq(go(COUNTER), go(DOCK))),
        Case("say hello everyone", say("hello everyone")),
        Case("tell everyone that dinner is ready", say("dinner is ready")),
        Case("wait for ten seconds", wait("10")),
        Case("pause for four seconds", wait("4")),
        Case("hey robot, could you get the bottle", fetch(BOTTLE)),
        Case("I'm hungry, bring me the apple", fetch(APPLE)),
        Case("now put it on the table", carry(BOTTLE, TABLE, held=True), held=BOTTLE),
        Case("bring that to me", fetch(MUG), history=(("find the red mug", find(MUG)),)),
        Case("the water bottle, take it to the counter", carry(BOTTLE, COUNTER)),
        Case("head to the living room please", go(TABLE)),
        Case("please look for the blue bottle", find(BOTTLE)),
        Case("go to the table and look around", seq(go(TABLE), LOOK)),
    ),
    stops=(
        "stop",
        "stop right away",
        "halt now",
        "freeze please",
        "robot, halt",
        "hey, stop",
        "emergency stop please",
        "okay stop",
        "stop, stop",
        "stop moving",
        "freeze, please",
        "please stop now",
    ),
    with_stop=(
        Case("go to the dock and stop there", go(DOCK)),
        Case("walk to the table and then stop", go(TABLE)),
        Case("fetch the mug and don't stop", fetch(MUG)),
        Case("carry on to the counter without stopping", go(COUNTER)),
    ),
    out_of_world=(
        "bring me a blanket",
        "go to the garage",
        "open the window",
        "water the plants",
        "put the apple in the fridge",
        "wash the dishes",
        "play some music",
        "do a cartwheel",
    ),
)

# A tenth set, written at stop 80 after `HELDOUT8` was measured and before its misses were read: what was changed from
# them, measured on voices and wordings it was not made on.
HELDOUT9 = SpokenSet(
    name="heldout9",
    voices=(
        Voice("en-gb-x-rp+adam", 160),
        Voice("en-us+Alicia", 165, 60),
        Voice("en-029+iven", 150, 45),
        Voice("en-us-nyc+Andy", 170, 50),
    ),
    commands=(
        Case("get me the green apple please", fetch(APPLE)),
        Case("could you grab the red mug for me", fetch(MUG)),
        Case("walk over to the dock", go(DOCK)),
        Case("go to the kitchen", go(COUNTER)),
        Case("head to the living room table", go(TABLE)),
        Case("carry the mug to the counter", carry(MUG, COUNTER)),
        Case("put the apple on the coffee table", carry(APPLE, TABLE)),
        Case("take the bottle to the charging dock", carry(BOTTLE, DOCK)),
        Case("where did the bottle go", find(BOTTLE)),
        Case("search for the red mug", find(MUG)),
        Case("look around please", LOOK),
        Case("tell me what you see", LOOK_AND_TELL),
        Case("go back home", HOME),
        Case("go back to your start", HOME),
        Case("grab the apple and put it on the counter", carry(APPLE, COUNTER)),
        Case("go to the table and then to the dock", seq(go(TABLE), go(DOCK))),
        Case("say good morning", say("good morning")),
        Case("announce that lunch is ready", say("lunch is ready")),
        Case("wait three seconds", wait("3")),
        Case("wait here for eight seconds", wait("8")),
        Case("excuse me, could you bring me the bottle", fetch(BOTTLE)),
        Case("I want the red mug", fetch(MUG)),
        Case("put it down on the table", carry(MUG, TABLE, held=True), held=MUG),
        Case("bring it over here", fetch(BOTTLE), history=(("where is the blue bottle", find(BOTTLE)),)),
        Case("the apple, take it to the dock", carry(APPLE, DOCK)),
        Case("please go to the charger", go(DOCK)),
        Case("try to find the green apple", find(APPLE)),
        Case("look around, then bring me the bottle", seq(LOOK, fetch(BOTTLE))),
    ),
    stops=(
        "stop",
        "stop it",
        "halt please",
        "freeze",
        "robot, freeze",
        "hey robot, stop",
        "emergency stop now",
        "okay, halt",
        "stop, please stop",
        "stop right there",
        "please halt now",
        "stop everything",
    ),
    with_stop=(
        Case("go to the table and stop next to it", go(TABLE)),
        Case("walk to the kitchen and stop there", go(COUNTER)),
        Case("bring me the bottle and don't stop", fetch(BOTTLE)),
        Case("fetch the apple without stopping", fetch(APPLE)),
    ),
    out_of_world=(
        "bring me a spoon",
        "go to the office",
        "turn on the tv",
        "feed the cat",
        "put the mug in the sink",
        "fold the laundry",
        "order a pizza",
        "do a somersault",
    ),
)

# An eleventh set, written at stop 80 after `HELDOUT9` was measured and before its stop misses were read.
HELDOUT10 = SpokenSet(
    name="heldout10",
    voices=(
        Voice("en-gb+Marco", 160),
        Voice("en-us+Jacky", 165, 55),
        Voice("en-gb-scotland+Hugo", 150, 45),
        Voice("en-us+Mario", 170),
    ),
    commands=(
        Case("fetch the blue bottle for me", fetch(BOTTLE)),
        Case("would you get me the mug please", fetch(MUG)),
        Case("walk to the charging station", go(DOCK)),
        Case("go over to the counter", go(COUNTER)),
        Case("move to the table please", go(TABLE)),
        Case("bring the apple to the kitchen counter", carry(APPLE, COUNTER)),
        Case("put the bottle on the counter", carry(BOTTLE, COUNTER)),
        Case("take the red mug to the living room", carry(MUG, TABLE)),
        Case("where's the green apple", find(APPLE)),
        Case("locate the red mug", find(MUG)),
        Case("look around the kitchen", LOOK),
        Case("what do you see", LOOK_AND_TELL),
        Case("go home", HOME),
        Case("return to where you began", HOME),
        Case("pick up the bottle and bring it to the table", carry(BOTTLE, TABLE)),
        Case("go to the dock and then go home", seq(go(DOCK), HOME)),
        Case("say see you later", say("see you later")),
        Case("announce that the kitchen is clean", say("the kitchen is clean")),
        Case("wait five seconds", wait("5")),
        Case("wait for two seconds please", wait("2")),
        Case("robot, please fetch me the apple", fetch(APPLE)),
        Case("I'd love the blue bottle", fetch(BOTTLE)),
        Case("place it on the counter", carry(APPLE, COUNTER, held=True), held=APPLE),
        Case("get it for me", fetch(MUG), history=(("where is the mug", find(MUG)),)),
        Case("the red mug, put it on the table", carry(MUG, TABLE)),
        Case("go to the living room", go(TABLE)),
        Case("look for the water bottle", find(BOTTLE)),
        Case("look around and then go to the counter", seq(LOOK, go(COUNTER))),
    ),
    stops=(
        "stop",
        "stop now",
        "halt",
        "freeze now",
        "robot, stop right now",
        "hey, freeze",
        "emergency stop",
        "okay, stop it",
        "halt, halt",
        "stop please",
        "please freeze",
        "stop the robot",
    ),
    with_stop=(
        Case("go to the counter and stop there", go(COUNTER)),
        Case("walk to the dock and stop when you get there", go(DOCK)),
        Case("get me the mug and don't stop", fetch(MUG)),
        Case("bring the apple without stopping", fetch(APPLE)),
    ),
    out_of_world=(
        "bring me a pillow",
        "go to the attic",
        "lock the door",
        "walk the cat",
        "put the bottle in the freezer",
        "mop the floor",
        "send a message to my mom",
        "do a handstand",
    ),
)

# written at stop 81, before any engine heard it and before any change of that stop was measured
HELDOUT11 = SpokenSet(
    name="heldout11",
    voices=(
        Voice("en-us+quincy", 160),
        Voice("en-gb-x-rp+Andrea", 165, 60),
        Voice("en-gb-x-gbcwmd+norbert", 155, 45),
        Voice("en-us-nyc+Gene", 170),
    ),
    commands=(
        Case("can you grab the apple for me", fetch(APPLE)),
        Case("i need the water bottle", fetch(BOTTLE)),
        Case("head over to the dock", go(DOCK)),
        Case("please walk to the kitchen counter", go(COUNTER)),
        Case("make your way to the coffee table", go(TABLE)),
        Case("carry the mug to the counter", carry(MUG, COUNTER)),
        Case("set the apple down on the table", carry(APPLE, TABLE)),
        Case("move the bottle to the living room", carry(BOTTLE, TABLE)),
        Case("have you seen the red mug", find(MUG)),
        Case("search for the apple", find(APPLE)),
        Case("take a look around", LOOK),
        Case("tell me what you can see", LOOK_AND_TELL),
        Case("go back home", HOME),
        Case("return to your starting position", HOME),
        Case("grab the mug and put it on the counter", carry(MUG, COUNTER)),
        Case("go to the table and then come back home", seq(go(TABLE), HOME)),
        Case("say hello there", say("hello there")),
        Case("tell everyone that dinner is served", say("dinner is served")),
        Case("wait three seconds", wait("3")),
        Case("hold on for four seconds", wait("4")),
        Case("robot, bring me the blue bottle please", fetch(BOTTLE)),
        Case("could i have the green apple", fetch(APPLE)),
        Case("drop it on the table", carry(MUG, TABLE, held=True), held=MUG),
        Case("bring it here", fetch(BOTTLE), history=(("find the bottle", find(BOTTLE)),)),
        Case("the apple, take it to the counter", carry(APPLE, COUNTER)),
        Case("go to the kitchen", go(COUNTER)),
        Case("find me the coffee mug", find(MUG)),
        Case("look around and then head to the dock", seq(LOOK, go(DOCK))),
    ),
    stops=(
        "stop",
        "stop right now",
        "halt",
        "freeze",
        "robot stop",
        "okay, halt",
        "emergency stop",
        "stop, please",
        "freeze, freeze",
        "stop it now",
        "hey robot, stop",
        "halt right there",
    ),
    with_stop=(
        Case("go to the dock and stop", go(DOCK)),
        Case("walk to the table and stop next to it", go(TABLE)),
        Case("fetch the bottle without a stop", fetch(BOTTLE)),
        Case("keep going to the counter, don't stop", go(COUNTER)),
    ),
    out_of_world=(
        "bring me the newspaper",
        "go to the basement",
        "turn on the lights",
        "feed the dog",
        "put the apple in the oven",
        "vacuum the carpet",
        "call my brother",
        "jump over the chair",
    ),
)

# written at stop 82, before anything heard it: four more voices, and everyday wording none of the sets above has
HELDOUT12 = SpokenSet(
    name="heldout12",
    voices=(
        Voice("en-us+travis", 155),
        Voice("en-gb-scotland+Michael", 165, 55),
        Voice("en-029+ed", 160, 45),
        Voice("en-gb-x-gbclan+Lee", 150, 60),
    ),
    commands=(
        Case("would you get me the mug please", fetch(MUG)),
        Case("fetch the green apple", fetch(APPLE)),
        Case("i'd like the bottle of water", fetch(BOTTLE)),
        Case("walk over to the charging station", go(DOCK)),
        Case("go and stand by the counter", go(COUNTER)),
        Case("head into the living room", go(TABLE)),
        Case("put the bottle on the kitchen counter", carry(BOTTLE, COUNTER)),
        Case("take the red mug over to the coffee table", carry(MUG, TABLE)),
        Case("leave the apple on the coffee table", carry(APPLE, TABLE)),
        Case("where is the blue bottle", find(BOTTLE)),
        Case("can you find the apple", find(APPLE)),
        Case("have a look around the room", LOOK),
        Case("what do you see", LOOK_AND_TELL),
        Case("head back to where you started", HOME),
        Case("go home now", HOME),
        Case("pick up the bottle and put it on the table", carry(BOTTLE, TABLE)),
        Case("first go to the counter, then go to the dock", seq(go(COUNTER), go(DOCK))),
        Case("say good night everyone", say("good night everyone")),
        Case("announce that the meeting starts now", say("the meeting starts now")),
        Case("wait for five seconds", wait("5")),
        Case("pause for two seconds", wait("2")),
        Case("hey robot, fetch me the red mug", fetch(MUG)),
        Case("i could use an apple", fetch(APPLE)),
        Case("put it down on the counter", carry(APPLE, COUNTER, held=True), held=APPLE),
        Case("now bring it to me", fetch(MUG), history=(("find the red mug", find(MUG)),)),
        Case("the bottle, put it on the counter", carry(BOTTLE, COUNTER)),
        Case("go over to the table in the living room", go(TABLE)),
        Case("look around, then go back home", seq(LOOK, HOME)),
    ),
    stops=(
        "stop",
        "stop now",
        "halt now",
        "freeze",
        "robot, halt",
        "emergency stop",
        "stop, stop",
        "please stop",
        "freeze right there",
        "stop immediately",
        "okay robot, stop",
        "halt, please",
    ),
    with_stop=(
        Case("walk to the counter and then stop", go(COUNTER)),
        Case("go to the table, stop there", go(TABLE)),
        Case("don't stop until you reach the dock", go(DOCK)),
        Case("grab the apple without stopping", fetch(APPLE)),
    ),
    out_of_world=(
        "bring me my glasses",
        "go to the garage",
        "open the fridge",
        "water the plants",
        "put the mug in the dishwasher",
        "sing me a song",
        "text my mom",
        "climb the stairs",
    ),
)

SETS: dict[str, SpokenSet] = {
    s.name: s
    for s in (
        DEV,
        HELDOUT,
        HELDOUT2,
        HELDOUT3,
        HELDOUT4,
        HELDOUT5,
        HELDOUT6,
        HELDOUT7,
        HELDOUT8,
        HELDOUT9,
        HELDOUT10,
        HELDOUT11,
        HELDOUT12,
    )
}


ROOM_SNR_DB = 40.0  # a quiet room
LEAD_S, TAIL_S = 0.4, 0.3  # quiet before and after the words, as a push-to-talk recording has


def utterance(text: str, voice: Voice, snr_db: float | None, seed: int) -> Audio:
    """A set's sentence spoken, with the quiet before and after it, clean (a quiet room) or in brown noise."""
    spoken = synthesize_audio(text, voice.name, voice.wpm, voice.pitch).samples
    padded = Audio(
        np.concatenate([np.zeros(int(LEAD_S * RATE), np.int16), spoken, np.zeros(int(TAIL_S * RATE), np.int16)])
    )
    if snr_db is None:
        return add_noise(padded, ROOM_SNR_DB, seed=seed)
    return add_noise(padded, snr_db, seed=seed, colour="brown")
