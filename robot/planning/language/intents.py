"""What one step of a command asks for: the action and the phrases that fill it, not yet looked up in the world.

Each kind of request has the shapes people say it in ("bring me the cup", "take a walk to the kitchen", "tell
everyone that dinner is ready", "where's the bottle"); the names inside stay phrases ("the cup", "the kitchen")
for `names` to resolve. A step that fits no shape is not guessed at: `read_step` returns None.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

from robot.navigation.goal import parse_pose_goal
from robot.planning.language.clauses import Clause
from robot.planning.language.lexicon import (
    CARRY_VERBS,
    FIND_VERBS,
    GO_VERBS,
    HAND_VERBS,
    MORE_NUMBER_WORDS,
    NUMBER_WORDS,
    PICK_VERBS,
    PLACE_WORDS,
    SAY_VERBS,
    TELL_VERBS,
    WAIT_VERBS,
    phrases,
    verbs,
    word_list,
)
from robot.planning.planner import PlanningError


@dataclass(frozen=True)
class Step:
    """One requested step. `action`: fetch (to the person when `to_me`), carry, go, find, look, look_and_tell,
    home, wait, stop, say, or topic (a thing named first, for a pronoun after it: "the red mug, bring it ...")."""

    action: str
    thing: str | None = None  # an object phrase
    source: str | None = None  # where the thing is said to be
    place: str | None = None  # where to go or put it, as said (raw: a pose keeps its punctuation)
    to_me: bool = False  # fetch: handed over ("bring me", "bring it here")
    text: str = ""  # say: the message as typed
    text_start: int = -1  # say: where the message starts in the raw command (to extend it)
    seconds: float | None = None  # wait

    @property
    def open_message(self) -> bool:
        """A say whose message comes after a colon ("announce: dinner is ready")."""
        return self.action == "say" and not self.text


def read_step(clause: Clause) -> Step | None:
    """The step a clause asks for (politeness already cut from its start), or None when it fits no shape."""
    said = _said(clause)
    if said is not None:
        return said
    # what is said after the request is cut off first; a shape may hold such words ("stop the robot")
    for read in (clause.without_suffixes().without_infixes(), clause.without_infixes()):
        for pattern, build in _shapes():
            match = pattern.fullmatch(read.text)
            if match:
                return build(match, read)
    return None


# --- say -----------------------------------------------------------------------------------------------------

_AUDIENCE = (
    r"(?:me|us|him|her|them|everyone|everybody|all|all of you|you all|people|the room|the house|everyone here|"
    r"everybody here|the whole house|the \w+|my \w+|our \w+|\w+(?= that))"
)


@cache
def _say_shapes() -> tuple[re.Pattern[str], ...]:
    loud = r"(?: (?:out loud|aloud|loudly|clearly|loud|out))?"
    return (
        re.compile(
            rf"(?:{verbs(*SAY_VERBS)}|call out){loud}(?: to (?P<aud>{_AUDIENCE}))?(?: (?:that|the following))?"
            rf"(?: (?P<msg>.+))?"
        ),
        re.compile(rf"{verbs(*TELL_VERBS)} (?P<aud>{_AUDIENCE})(?: that)?(?: (?P<msg>.+))?"),
        re.compile(rf"let (?P<aud>{_AUDIENCE}) know(?: that)?(?: (?P<msg>.+))?"),
        re.compile(
            r"(?:make|give) an? (?:announcement|statement|shout out)(?: to (?:everyone|everybody|all))?"
            r"(?: (?:that|saying))?(?: (?P<msg>.+))?"
        ),
    )


_NOT_A_MESSAGE = re.compile(r"(?:what|where|how|who|which|when|why|whether|if)\b.*|what you (?:can )?see")
_BARE_THING = re.compile(r"(?:a|an|the|some|your|my|our) \w+(?: \w+)?")
_VERB_LIKE = re.compile(r"\b(?:is|are|was|were|will|has|have|had|can|am|be|do|does|did|not|s)\b")


def _said(clause: Clause) -> Step | None:
    for pattern in _say_shapes():
        match = pattern.fullmatch(clause.text)
        if match is None:
            continue
        message = match.group("msg")
        if message is None:
            return Step("say")  # its message follows a colon
        if _NOT_A_MESSAGE.fullmatch(message):
            return None  # "tell me what you see", "tell me where the mug is": not a sentence to repeat
        told = pattern is not _say_shapes()[0]  # "tell me a joke", not "say a word"
        if told and _BARE_THING.fullmatch(message) and not _VERB_LIKE.search(message):
            raise PlanningError(
                f"I can only say a sentence you give me (e.g. 'tell everyone that dinner is "
                f"ready'), not make up {message!r}"
            )
        start = match.start("msg")
        return Step("say", text=clause.raw_of(start, match.end("msg")), text_start=clause.raw_start(start))
    return None


# --- everything else -----------------------------------------------------------------------------------------

_STOP = (
    r"(?:stop|halt|freeze|stand still|stop moving|cancel|abort|emergency stop|e stop|stop what you are doing|"
    r"hold it|do not move|cancel that|stop that|cancel everything|stop everything|stop the robot|stop all|"
    r"never mind|forget it|forget about it)"
    r"(?: (?:stop|halt|freeze|now|right now|immediately|please|at once|robot|right there|there|right here|here|"
    r"everything|moving|it|all))*"
)
# where or when a walk ends, said after it: "(go to the dock and) stop next to it", "stop once you get there"
_STOP_AT_THE_END = (
    r"(?:stop|halt|pull up|come to a stop)(?: (?:right|just))? (?:(?:next to|beside|by|near|in front of|close to|"
    r"alongside|at|right by|right next to) (?:it|that|them|this|there|here)|(?:when|once|as soon as|after|where) "
    r"you(?: will| have)? (?:get|arrive|are|reach|come|got|arrived)(?: (?:there|here|near|close|to it|it|near it|"
    r"close to it|next to it|in front of it))?)"
)
_AROUND = (
    r"(?: (?:around you|around|here|in the room|right now|in front of you|near you|nearby|over there|there|"
    r"from where you are|from there|from here))?"
)
_LOOK_AND_TELL = (
    r"(?:(?:tell me|let me know|say|describe|report|can you tell me|tell me about) )?"
    r"(?:(?:what|which objects|what things) (?:do|can) you (?:see|spot|make out)|"
    r"what you (?:can |will |would )?(?:see|spot)|"
    rf"what are you seeing|what is (?:around|near|in front of|close to)(?: you| here)?|what have you seen|"
    rf"what can you spot|the scene|your surroundings|what you are seeing|what is there){_AROUND}|"
    r"describe (?:it|that|everything|all of it|the room)"  # after a look: "have a look around and describe it"
)
_HOME = (
    r"(?:(?:go|come|head|walk|return|get|run|move|drive)(?: on)?(?: back)?(?: to)? (?:home|your home|your start|"
    r"where you started|where you began|the start|the starting point|your starting (?:point|position|spot|place)|"
    r"your start position|base|the beginning|where you came from|where you started from|where you began|start|"
    r"where you belong|where you were(?: before| at first| at the start)?|where you set off(?: from)?|"
    r"where you started off|"
    r"(?:your |the )?(?:home|start|starting|initial) (?:position|point|spot|place|pose|location|base)|"
    r"your starting point again)|home|back home|go home)"
)
_ROOMS = phrases(
    (
        "the room",
        "the area",
        "the place",
        "here",
        "you",
        *(f"the {w}" for w in word_list("kitchen, living room, lounge, sitting room, house, apartment, flat")),
    )
)
_LOOK = (
    rf"(?:(?:have|take) a (?:quick |little |good |short )?)?(?:{verbs('look', 'glance', 'peek')})"
    rf"(?: all)?(?: (?:around|round|about))(?: {_ROOMS})?(?: everywhere)?|"
    rf"scan (?:around|your surroundings|{_ROOMS})|check (?:your|the) surroundings|"
    rf"survey (?:your surroundings|{_ROOMS})|have a look round"
)
_CHARGE = (
    r"(?:go |go and |go to |come )?(?:re)?charge(?: yourself| up| your batter(?:y|ies)| itself)?"
    rf"(?: (?:at|on|by) (?:the |your )?(?:{phrases(PLACE_WORDS['dock'])}))?|"
    r"(?:go )?dock(?: yourself)?|go (?:re)?charge"
)
# the little words between a verb and a place, longest first ("on top of" before "on")
_SOURCE = phrases(word_list("from, off of, off, out of, on, at, in, up from, up off, on top of"))
_AWAY = phrases(word_list("back, over, down, off, up, away, across"))
_ONTO = phrases(
    word_list("""to, onto, on, into, in, at, over to, on to, back to, down on, down at, off at, on top of, next to,
                 by, near, beside, inside, up on, over on, down to, across to, in to, down onto, back on""")
)
_HERE = phrases(word_list("here, to me, to us, over to me, back to me, over here, back here, this way, my way, over"))
_GO_TO = phrases(
    word_list("to, towards, toward, into, in to, over to, up to, down to, round to, across to, onto, on to")
)


def _thing(m: re.Match[str], action: str, to_me: bool = False) -> Step:
    groups = m.groupdict()
    return Step(action, thing=groups.get("thing"), source=groups.get("source"), to_me=to_me)


def _find(m: re.Match[str], clause: Clause) -> Step:
    return _thing(m, "find")


def _fetch(m: re.Match[str], clause: Clause) -> Step:
    return _thing(m, "fetch")


def _hand_over(m: re.Match[str], clause: Clause) -> Step:
    """Fetched for the person who asked ("bring me the cup", "bring it here")."""
    return _thing(m, "fetch", to_me=True)


def _go(m: re.Match[str], clause: Clause) -> Step:
    """A walk to a place named in words, or to a pose ("1.2, 0.5, 90 deg": its punctuation is kept)."""
    raw = clause.raw_of(m.start("place"), m.end("place"))
    return Step("go", place=raw if parse_pose_goal(raw) is not None else m.group("place"))


def _carry(m: re.Match[str], clause: Clause) -> Step:
    if re.fullmatch(r"(?:me|us|you|here|me here|the person|whoever asked)", m.group("place")):
        return _hand_over(m, clause)
    return Step("carry", thing=m.group("thing"), source=m.groupdict().get("source"), place=m.group("place"))


_SOUNDS_LIKE_A_NUMBER = {"for": "four", "to": "two", "too": "two"}


def _wait(m: re.Match[str], clause: Clause) -> Step:
    amount = _number(_SOUNDS_LIKE_A_NUMBER.get(m.group("n"), m.group("n")))
    if amount is None:
        raise PlanningError(f"how long is {m.group('n')!r}? say a number of seconds, e.g. 'wait 5 seconds'")
    per_unit = 60.0 if (m.group("unit") or "").startswith("min") else 1.0
    return Step("wait", seconds=amount * per_unit)


Build = Callable[[re.Match[str], Clause], Step]


@cache
def _shapes() -> tuple[tuple[re.Pattern[str], Build], ...]:
    go_first = r"(?:go |come |go and |come and )?"
    wait_verbs = (
        rf"(?:{verbs(*WAIT_VERBS)}|hold on|hang on|hold|hang tight|sit tight|stay|stay still|stay put|"
        r"stand still|stand by|hold still|stand there|stand)"
    )
    shapes: list[tuple[str, Build]] = [
        (_STOP, lambda m, c: Step("stop")),
        (_STOP_AT_THE_END, lambda m, c: Step("stop")),
        (rf"{_GO_TO} (?P<place>.+)", _go),  # "off you go, to the kitchen"
        # "and tell me when you're done": the plan's last step says so anyway
        (
            r"(?:tell|let) (?:me|us)(?: know)? (?:when|once) (?:you are|you have|it is|that is) (?:done|finished|"
            r"there|ready)",
            lambda m, c: Step("nothing"),
        ),
        # "hang on, wait thirty seconds": a word to hold the robot's attention before the request, asking nothing
        (r"hang on|hold on|hang about", lambda m, c: Step("nothing")),
        (_LOOK_AND_TELL, lambda m, c: Step("look_and_tell")),
        (_HOME, lambda m, c: Step("home")),
        (_LOOK, lambda m, c: Step("look")),
        (
            rf"{wait_verbs}(?: (?:there|here|still|put))?(?: for)?(?: (?:about|around|roughly|just|another))? "
            rf"(?P<n>{_NUMBER})(?: ?(?P<unit>seconds?|secs?|s|minutes?|mins?))?",
            _wait,
        ),
        # "wait four seconds" as a recogniser often writes it: a number that sounds like "for", "to" or "too"
        (rf"{wait_verbs} (?:for )?(?P<n>for|to|too) (?P<unit>seconds|minutes)", _wait),
        # time asked for: "give me five seconds", "give it a minute", "just a second" (the twenty-fifth spoken set,
        # stop 91); the unit is needed here, so "give me two apples" stays a request for things
        (
            rf"(?:(?:give|allow|grant) (?:me|us|it)(?: (?:about|around|roughly|just|another))? |just |only )?"
            rf"(?P<n>{_NUMBER}) (?P<unit>seconds?|secs?|minutes?|mins?)",
            _wait,
        ),
        (_CHARGE, lambda m, c: Step("go", place="charger")),
        # a walk named by a noun: "take a walk to the kitchen", "make your way to the dock"
        (
            rf"(?:take|go for|have|make|do|go on|go) (?:a |an )?(?:little |short |quick |brief |small |nice )?"
            rf"(?:walk|stroll|trip|wander|amble|hike|journey|run)(?: {_AWAY})? {_GO_TO} (?P<place>.+)",
            _go,
        ),
        (rf"(?:make|find) your way(?: {_AWAY})? {_GO_TO} (?P<place>.+)", _go),
        # "keep going to the counter", "carry on walking over to the dock", "carry on to the counter"
        (
            r"(?:keep|carry on|continue)(?: on)? (?:going|walking|moving|heading|driving)(?: on| straight| right)?"
            rf"(?: over)? {_GO_TO} (?P<place>.+)",
            _go,
        ),
        (rf"(?:carry on|keep on|continue on|go on|move on)(?: over)? {_GO_TO} (?P<place>.+)", _go),
        (
            rf"(?:{verbs(*GO_VERBS)}|get yourself|pop|nip|hop|swing)(?: on| straight| right)?(?: {_AWAY})?"
            rf"(?: over)? {_GO_TO} (?P<place>.+)",
            _go,
        ),
        (rf"(?:{verbs(*GO_VERBS)})(?: {_AWAY})? (?P<place>there|over there)", _go),
        # a visit: "stop by the kitchen", "drop in at the dock", "swing by the table"
        (
            rf"(?:{verbs('stop', 'drop', 'pop', 'swing', 'call')})(?: {_AWAY})? "
            r"(?:by|at|in at|in on|round|round to|off at) (?P<place>.+)",
            _go,
        ),
        # a walk to its end: "don't stop until you reach the table", "keep walking till you get to the dock"
        (
            rf"(?:do not stop|(?:keep|carry on|continue)(?: on)?(?: (?:going|walking|moving|driving))?|"
            rf"(?:{verbs(*GO_VERBS)})(?: on)?(?: straight)?) (?:until|till|til) you (?:reach|get to|arrive at|"
            r"are at|get at|make it to|come to) (?P<place>.+)",
            _go,
        ),
        # "go stand by the charger", "wait at the table"
        (
            r"(?:go (?:and )?)?(?:stand|wait|stay|park yourself|position yourself) (?:by|at|next to|near|beside|"
            r"in front of) (?P<place>.+)",
            _go,
        ),
        # find
        (
            rf"{go_first}(?:{verbs(*FIND_VERBS)}(?: out| me| us)?|{verbs('look')} (?:around |about |everywhere )?for|"
            rf"{verbs('look')} at|"
            rf"{verbs('search', 'check')}(?: (?:around|everywhere|{_ROOMS}))? for|"
            rf"{verbs('hunt')}(?: around)? for|(?:have|take) a look(?: around)? for|check for|"
            r"(?:look out|keep an eye out|keep a look out|watch out|watch) for|see if you can "
            r"(?:find|spot|see)|try to find|see|spot) (?P<thing>.+?)(?: (?:anywhere|around|here|in the room|"
            r"around here|nearby))?",
            _find,
        ),
        (
            r"where (?:did|has|have|does) (?P<thing>.+?) (?:go|gone|went|get to|got to|end up|ended up|disappear to)",
            _find,
        ),
        # "where did I leave the bottle", "where have you put my mug"
        (
            r"where (?:did|have|had|do) (?:i|you|we|they|he|she|someone|somebody|anyone|anybody)(?: last)? "
            r"(?:leave|left|put|see|seen|saw|drop|dropped|place|placed|move|moved|set|hide|hid|hidden|keep|kept) "
            r"(?P<thing>.+?)(?: (?:now|last|at the moment|earlier|today|yesterday))?",
            _find,
        ),
        (
            r"(?:where is|where are|where can i find|where) (?P<thing>.+?)"
            r"(?: (?:now|at the moment|right now|gone|go|at))?",
            _find,
        ),
        (
            r"(?:check|tell me|show me|find out|do you know|can you tell me|let me know|see|say) where (?P<thing>.+?)"
            r" (?:is|are|went|has gone)(?: now| located| kept| at the moment| right now)?",
            _find,
        ),
        (r"(?:is|are) (?P<thing>.+?) (?:anywhere(?: around| here| nearby)?|around(?: here)?|nearby|here)", _find),
        (
            r"(?:can you see|do you see|is there|are there|have you seen|did you see) (?P<thing>.+?)"
            r"(?: (?:anywhere|around|here|around here))?",
            _find,
        ),
        # handed over: "bring me the cup", "bring it here", "I'd like the apple"
        (
            rf"{go_first}{verbs(*HAND_VERBS)} (?:me|us)(?: over)? (?P<thing>.+?)(?: {_SOURCE} (?P<source>.+?))?"
            rf"(?: {_HERE})?",
            _hand_over,
        ),
        (
            rf"{go_first}{verbs('bring', 'fetch', 'get', 'carry', 'take', 'grab', 'give', 'hand', 'pass')} "
            rf"(?P<thing>.+?)(?: {_SOURCE} (?P<source>.+?))? {_HERE}",
            _hand_over,
        ),
        # "I want the apple on the table": put there; "I'd like the apple": handed over
        (
            r"(?:i want|i need|i would like) (?P<thing>.+?) (?:put |placed |moved |taken |brought )?"
            r"(?:on|onto|to|at|in|on top of) (?P<place>.+)",
            _carry,
        ),
        (
            r"(?:i want|i wanted|i need|i would like|i would love|i could use|i could do with|can i have|may i have|"
            r"can i get|could i have|could i get|"
            r"i will have|i will take|give me|i want to have|i would like to have|can i please have|could i please "
            rf"have) (?P<thing>.+?)(?: {_SOURCE} (?P<source>.+?))?",
            _hand_over,
        ),
        # carry somewhere
        (
            rf"{go_first}{verbs(*CARRY_VERBS)} (?P<thing>.+?)(?: (?:from|off of|off|out of) (?P<source>.+?))?"
            rf"(?: {_AWAY})? {_ONTO} (?P<place>.+)",
            _carry,
        ),
        (
            rf"{go_first}{verbs(*CARRY_VERBS)} (?P<thing>.+?)(?: {_AWAY})?(?: {_ONTO})? (?P<place>there|over there)",
            _carry,
        ),
        # "bring the mug", "bring over the bottle": to the person who asked
        (
            rf"{go_first}{verbs('bring', 'fetch', 'pass', 'hand')}(?: over| back| along| round)? (?P<thing>.+?)"
            rf"(?: {_SOURCE} (?P<source>.+?))?",
            _hand_over,
        ),
        # pick up
        (
            rf"{go_first}{verbs(*PICK_VERBS)}(?: up)? (?P<thing>.+?)(?: up| down| out)?(?: {_SOURCE} (?P<source>.+?))?"
            r"(?: up)?",
            _fetch,
        ),
        # last, "go kitchen": a recognition error dropped the small word; only verbs that always mean walking
        (rf"{verbs('go', 'walk', 'head', 'navigate', 'drive', 'travel', 'proceed')} (?P<place>.+)", _go),
    ]
    return tuple((re.compile(pattern), build) for pattern, build in shapes)


def elliptic_step(clause: Clause, previous: Step) -> Step | None:
    """A step said without its verb, after one with it: "go to the table, then the dock", "find the apple, then
    the mug"."""
    if previous.action == "go":
        place = re.match(rf"(?:(?:over |back )?{_GO_TO} )?(?P<place>.+)", clause.text)
        return _go(place, clause) if place else None
    if previous.action == "find":
        return Step("find", thing=clause.text)
    return None


_NUMBER = (
    r"\d+(?:\.\d+)?|(?:twenty|thirty|forty|fifty) (?:one|two|three|four|five|six|seven|eight|nine)|"
    + phrases(tuple({**NUMBER_WORDS, **MORE_NUMBER_WORDS}))[3:-1]
)


def _number(text: str) -> float | None:
    text = text.strip()
    words = {**NUMBER_WORDS, **MORE_NUMBER_WORDS}
    if text in words:
        return float(words[text])
    parts = text.split()
    if len(parts) == 2 and parts[0] in words and parts[1] in words and words[parts[0]] >= 20:
        return float(words[parts[0]] + words[parts[1]])  # "twenty five"
    try:
        return float(text)
    except ValueError:
        return None
