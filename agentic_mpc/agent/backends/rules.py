"""The embedded offline backend: a deterministic, rule-based interpreter. It is NOT a language model.

It stands in for the paper's LLM where none is available (tests, ``agentic-mpc ask`` by default, offline
demos). It understands a small grammar of driving requests and nothing else; for anything it does not
recognise it makes no tool call and says so. Use the ``openai`` backend for a real model.

The grammar
-----------
A message is normalised (lower case, contractions expanded: "don't" -> "do not"), split into clauses at
sentence punctuation, commas, "but", "and then"; "rather than X" / "instead of X" become "not X". In each
clause it finds:

- sides: "left" / "right" where they name a side (not "right now", "the ambulance left"); a negation earlier
  in the clause ("not", "never", "no", "without", "avoid passing ...") flips the side; "keep the obstacle on
  our left" means evading to the right;
- lanes: "left/right/center/middle lane", "change lanes to the left", "back to our lane";
- speeds: a number (digits or words) with a unit: km/h (kph, kmh, kilometres per hour), mph (miles per
  hour), m/s (mps, metres per second); "by X" is relative, "at most / no faster than / under X" caps,
  "at least X" floors; "stop" / "halt" / "pull over" is 0; "slow down" / "speed up" without a number scale
  the current reference speed by 0.75 / 1.25;
- emergency vehicles (ambulance, fire engine, police car, siren, ...): coming, behind, approaching or "let
  them pass" means yield (the yield lane, default left as in the paper, at 0 m/s unless a side or a speed
  is given); gone, passed, went by, all clear, false alarm means resume: the INITIAL specification's lane
  and speed, read from the system message;
- resume / restore ("carry on", "back to normal", "reset to the original settings");
- no preference ("either side is fine", "forget the steering preference").

Intents map to tools: yield/resume/lane -> ``run_<lane>_lane(v_ref)`` (the current speed unless one is
given; a stopped car changing lane uses the initial speed), speed -> ``set_reference_speed``, side ->
``set_preferred_steering_direction``, no preference -> ``clear_preferred_steering_direction``. Speeds above
the tool's schema maximum are clamped to it (and the reply says so). Questions ("which lane are we in?"),
conditions about the future ("if an ambulance comes, ...") and small talk give no tool call; the reply
describes the current specification. After tool results it answers with a summary and no call, so the
agent step ends.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from agentic_mpc.agent.backends.base import BackendReply, ToolSpec
from agentic_mpc.agent.messages import Message, ToolCall

Side = Literal["left", "right"]
LANE_NAMES = {"left": "left", "right": "right", "center": "center", "centre": "center", "middle": "center",
              "central": "center"}

KMH_TO_MPS = 1 / 3.6
MPH_TO_MPS = 0.44704
SLOW_DOWN_FACTOR = 0.75
SPEED_UP_FACTOR = 1.25

# ---------------------------------------------------------------------------------------------- lexicon
_NUMBER_WORDS = {
    "zero": 0, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
    "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "thirteen": 13, "fourteen": 14, "fifteen": 15,
    "sixteen": 16, "seventeen": 17, "eighteen": 18, "nineteen": 19, "twenty": 20, "thirty": 30, "forty": 40,
    "fifty": 50, "sixty": 60, "seventy": 70, "eighty": 80, "ninety": 90, "hundred": 100,
}
_UNITS = {
    "kmh": r"(?:km\s*/\s*h(?:r|our)?|km\s*h|kmh|kph|kmph|k\.?p\.?h\.?|kilomet(?:er|re)s?\s*(?:per|an|a|/)\s*hour)",
    "mph": r"(?:mph|m\.p\.h\.?|mi\s*/\s*h|miles?\s*(?:per|an|a|/)\s*hour)",
    "mps": r"(?:m\s*/\s*s(?:ec)?\b|mps|m\s*s\^?-1|met(?:er|re)s?\s*(?:per|a|/)\s*second)",
}
_UNIT = "|".join(f"(?P<{name}>{pattern})" for name, pattern in _UNITS.items())
_NUMBER = r"(?P<num>-?\d+(?:\.\d+)?)"
_SPEED = re.compile(rf"{_NUMBER}\s*(?:{_UNIT})")
_BARE_SPEED = re.compile(
    r"\b(?:to|at|go|drive|doing|speed(?: of)?|of)\s+(?P<num>\d+(?:\.\d+)?)\b"
    r"(?!\s*(?:m\b|meters?|metres?|km\b|seconds?|s\b|%|percent))"
)

_EMERGENCY = re.compile(
    r"\b(?:ambulances?|fire ?(?:trucks?|engines?|brigade)|firetrucks?|police(?: cars?| vehicles?| vans?)?|"
    r"cop cars?|cops|emergency vehicles?|emergency services|sirens?|paramedics?|rescue (?:vehicles?|trucks?)|"
    r"blue lights|flashing lights)\b"
)
_GONE = re.compile(
    r"\b(?:gone|passed|went (?:by|past)|drove (?:by|past|off)|got (?:by|past|through)|(?:is|are) past|"
    r"overtook|overtaken|(?:is|are) (?:now )?ahead|ahead of us|all clear|(?:is|are) clear|coast is clear|"
    r"left us|moved on|no longer|not (?:behind|there|around|coming)|any ?more|disappeared|out of sight|"
    r"false alarm|has left|have left|is away|far away|went away|drove away|(?:it|they) left)\b"
)
_YIELD = re.compile(
    r"\b(?:let (?:them|it|him|her|(?:the|that|this|an?) [\w ]{1,25}?)\s*(?:pass|by|through|go)|"
    r"allow (?:them|it|(?:the|that|this) [\w ]{1,25}?) to pass|"
    r"make (?:way|room|space)|give way|pull over|move (?:aside|over|out of the way)|get out of (?:the|its|their) way|"
    r"clear the (?:way|road|lane)|yield|coming|approaching|behind us|behind|on our tail|catching up|"
    r"in a hurry|rushing|needs? to get (?:through|by|past)|wants? to (?:pass|get by)|trying to (?:pass|get by)|"
    r"from behind|on its way)\b"
)
_PRESENCE = re.compile(
    r"\b(?:there is|there are|i (?:can )?(?:see|hear)|we (?:have|got)|look|watch out|careful|heads up|"
    r"sirens?|flashing|blue lights|here comes?)\b"
)
_ONCOMING = re.compile(r"\b(?:oncoming|opposite (?:direction|lane|way|side)|other way|towards us|toward us)\b")
_STEERING_CONTEXT = re.compile(
    r"\b(?:obstacles?|obstructions?|objects?|debris|rocks?|cones?|barriers?|blockage|pothole|"
    r"avoid\w*|evad\w*|pass(?:ing)?|around|round|dodg\w*|swerv\w*|steer\w*|overtak\w*|go(?:ing)? by|"
    r"side|veer\w*|bypass\w*|skirt\w*|circumvent\w*|detour)\b"
)
_LANE_MOVE = re.compile(
    r"\b(?:lanes?|change over|merge|move over|shift over|switch over|get over|pull (?:in|over) to)\b"
)
_RESUME = re.compile(
    r"\b(?:resume|carry on|continue(?: driving| on| as (?:before|usual))?|drive on|keep going|go again|"
    r"start (?:driving|moving|going) again|get going|get moving|back to normal|as (?:before|usual|you were)|"
    r"we can go|you can go|normal driving|back on track|move on)\b|\blet us go(?: again| now)?\s*$"
)
_RESTORE = re.compile(
    r"\b(?:reset|restore|revert|undo|(?:back|return) to (?:the |your |our )?(?:original|initial|default|"
    r"previous|old|start)\w*)\b"
)
_CLEAR_PREFERENCE = re.compile(
    r"(?:\b(?:no|any|either|whichever|whatever) (?:preference|side|way|direction)\b|"
    r"\b(?:do|does|did) not (?:care|mind|matter)\b|\bnot matter\b|\bnot fussy\b|"
    r"\b(?:forget|drop|remove|clear|cancel|reset|ignore|delete|withdraw)\b[\w\s]*\b(?:preference|bias)\b|"
    r"\bstop (?:preferring|favou?ring)\b|\b(?:either|both) (?:sides?|ways?)\b|\bup to you\b|\bfree to choose\b|"
    r"\byour (?:choice|call)\b|\bno longer prefer\b)"
)
_STOP = re.compile(r"\b(?:stop|halt|standstill|come to a (?:full )?stop|pull over|park|freeze)\b(?!\s+\w+ing\b)")
_SLOW = re.compile(
    r"\b(?:slow (?:down|it down|up)|slower|(?:go|drive|move|proceed|take it) (?:more )?slow(?:ly)?|slowly|"
    r"decelerat\w*|reduce (?:the |your |our )?speed|ease (?:off|up)|take it easy|too fast|brake|not so fast|"
    r"less fast|(?:lower|drop|cut) (?:the |your |our )?speed)\b"
)
_FAST = re.compile(
    r"(?:\b(?:speed (?:it )?up|(?:go|drive|move|get|bit|little|lot|much|be|way) faster|accelerat\w*|hurry(?: up)?|"
    r"pick up (?:the )?(?:pace|speed)|(?:increase|raise) (?:the |your |our )?speed|step on it|go quicker|"
    r"too slow|get a move on)\b|^faster\b)"
)
_CAP = re.compile(r"\b(?:at most|no (?:more|faster) than|not (?:more|faster) than|max(?:imum)?(?: of)?|below|under|"
                  r"not (?:above|exceed\w*)|up to|limit(?: it| the speed| our speed)? to|keep (?:it )?under|"
                  r"speed limit\b[\w\s]{0,15}?(?:is|of)?)\s*$")
_FLOOR = re.compile(r"\b(?:at least|no (?:less|slower) than|not (?:less|slower) than|min(?:imum)?(?: of)?|above)\s*$")
_BY = re.compile(r"\bby\s*$")
_COMPARISON = re.compile(r"\b(faster|more|quicker|above|over|slower|less|below)\s+than\s*$")
_NEGATION = re.compile(
    r"\b(?:not|no|never|without|nor|neither|avoid(?:ing)? (?:going|passing|steering|swerving|turning|dodging|"
    r"veering|evading|moving)|rather not|refrain from|instead of)\b"
)
# "do not hesitate to pass on the left" is no negation of "left".
_NEUTRAL_NEGATION = re.compile(r"\b(?:not|never)\s+(?:hesitate|forget|fail|be afraid|worry)\b")
_INVERTED_SIDE = re.compile(
    r"\b(?:keep|leave|have|put)\s+(?:the |that |this )?(?:obstacles?|obstructions?|objects?|it|them|debris|rocks?|"
    r"cones?|barriers?|thing)\s+(?:on|to)\s+(?:our|your|my|the)\s+(?P<side>left|right)"
)
_QUESTION_START = re.compile(
    r"^(?:what|which|how|why|where|when|who|whose|is|are|am|was|were|do|does|did|have|has|had)\b"
    r"(?!\s+about\b)(?!\s+not\b)"
)
_CONDITIONAL_START = re.compile(r"^(?:if|when|whenever|in case|once|as soon as|should an?|unless)\b")
_SIDE_WORD = re.compile(r"\b(?P<side>left|right)\b")
# "left" and "right" name a side unless the words around them say otherwise: "the ambulance left",
# "nothing left", "all right", "that is right", "right now", "the right thing", "Right, ..." (an interjection).
_LEFT_AS_VERB_BEFORE = {
    "it", "they", "he", "she", "we", "i", "you", "has", "have", "had", "just", "already", "who", "that", "which",
    "ambulance", "truck", "car", "vehicle", "engine", "police", "nothing", "anything", "something", "time",
    "is", "are", "was", "were", "be", "been", "being", "siren",
}
_RIGHT_AS_ADJECTIVE_BEFORE = {"all", "is", "are", "was", "were", "be", "quite", "exactly", "am", "so", "not", "very"}
_SIDE_AFTER = {"side", "lane", "hand", "of", "lanes", "sides"}
_NOT_A_SIDE_AFTER = {
    "now", "away", "there", "here", "behind", "after", "before", "in", "thing", "decision", "choice", "call",
    "idea", "time", "moment", "answer", "way", "track", "amount", "us", "it", "them", "the", "a", "an", "home",
    "early", "off", "for", "at", "turn",
}


# ---------------------------------------------------------------------------------------------- parsing
def normalise(text: str) -> str:
    """Lower case, plain quotes, contractions expanded, number words before units as digits."""
    s = text.lower().replace("\u2019", "'").replace("\u2018", "'").replace("`", "'")
    s = re.sub(r"\bcan't\b|\bcannot\b", "can not", s)
    s = re.sub(r"\bwon't\b", "will not", s)
    s = re.sub(r"\bshan't\b", "shall not", s)
    s = re.sub(r"n't\b", " not", s)
    s = re.sub(r"\blet's\b", "let us", s)
    s = re.sub(r"'d\b", " would", s)
    s = re.sub(r"'re\b", " are", s)
    s = re.sub(r"'ll\b", " will", s)
    s = re.sub(r"'ve\b", " have", s)
    s = re.sub(r"\b(it|that|there|what|he|she|who|where|here)'s\b", r"\1 is", s)
    s = re.sub(r"\bi'm\b", "i am", s)
    s = re.sub(r"\b(right|left)-hand\b", r"\1 hand", s)
    s = re.sub(r"\b(right|left)wards?\b", r"to the \1", s)
    s = re.sub(r"\b(?:rather than|instead of|other than|as opposed to)\b", ", not", s)
    return _numbers_from_words(s)


def _numbers_from_words(s: str) -> str:
    words = "|".join(_NUMBER_WORDS)
    pattern = re.compile(rf"\b((?:(?:{words})[\s-]?)+)(?=\s*(?:{_UNIT}))")

    def convert(match: re.Match[str]) -> str:
        total, current = 0, 0
        for word in re.split(r"[\s-]+", match.group(1).strip()):
            value = _NUMBER_WORDS[word]
            if value == 100:
                current = max(current, 1) * 100
            else:
                current += value
        total += current
        return f"{total} "

    return pattern.sub(convert, s)


def clauses(s: str) -> list[str]:
    # A "." inside a number ("12.5 m/s") does not end a clause.
    parts = re.split(r"[!?;,]+|[.:]+(?=\s|$)|\s+but\s+|\s+and then\s+|\s+then\s+|\s+however\s+|\s+though\s+", s)
    return [p.strip() for p in parts if p.strip()]


@dataclass(frozen=True, slots=True)
class SideMention:
    side: Side
    negated: bool

    @property
    def meaning(self) -> Side:
        return ("left" if self.side == "right" else "right") if self.negated else self.side


def side_mentions(clause: str) -> list[SideMention]:
    """Each "left"/"right" that names a side, with whether it is negated (or inverted) in the clause."""
    mentions: list[SideMention] = []
    inverted = {m.start("side") for m in _INVERTED_SIDE.finditer(clause)}
    for match in _SIDE_WORD.finditer(clause):
        before = clause[: match.start()].split()
        after = clause[match.end():].split()
        prev_word = before[-1] if before else ""
        next_word = after[0] if after else ""
        if next_word not in _SIDE_AFTER:
            if next_word in _NOT_A_SIDE_AFTER and not (next_word == "at" and prev_word in ("the", "on")):
                continue
            if match.group("side") == "left" and prev_word in _LEFT_AS_VERB_BEFORE:
                continue
            interjection = clause.strip() == "right"
            if match.group("side") == "right" and (prev_word in _RIGHT_AS_ADJECTIVE_BEFORE or interjection):
                continue
        negated = _is_negated(clause[: match.start()])
        if match.start() in inverted or _BLOCKED_AFTER.match(clause[match.end():]):
            negated = not negated  # "keep it on our left", "the right side is blocked": evade the other way
        mentions.append(SideMention(match.group("side"), negated))  # type: ignore[arg-type]
    return mentions


def _is_negated(prefix: str) -> bool:
    """Whether the text before a word puts it under a negation (a neutral "do not hesitate" does not count)."""
    cleaned = _NEUTRAL_NEGATION.sub(" ", prefix)
    return bool(_NEGATION.search(cleaned))


@dataclass(frozen=True, slots=True)
class SpeedPhrase:
    value_mps: float
    mode: Literal["set", "by", "cap", "floor"]
    negated: bool
    text: str


def speed_phrases(clause: str) -> list[SpeedPhrase]:
    found = []
    for match in _SPEED.finditer(clause):
        value = float(match.group("num"))
        unit = next(name for name in _UNITS if match.group(name))
        mps = value * {"kmh": KMH_TO_MPS, "mph": MPH_TO_MPS, "mps": 1.0}[unit]
        prefix = clause[: match.start()]
        mode: Literal["set", "by", "cap", "floor"] = "set"
        comparison = _COMPARISON.search(prefix)
        if _BY.search(prefix):
            mode = "by"
        elif _CAP.search(prefix):
            mode = "cap"
        elif _FLOOR.search(prefix):
            mode = "floor"
        elif comparison is not None:
            # "not faster than X" caps, "not slower than X" floors; "slower than X" caps, "faster than X" floors.
            upper = comparison.group(1) in ("faster", "more", "quicker", "above", "over")
            mode = "cap" if upper == _is_negated(prefix[: comparison.start()]) else "floor"
        negated = mode == "set" and _is_negated(prefix)
        found.append(SpeedPhrase(round(mps, 3), mode, negated, match.group(0)))
    return found


@dataclass
class Interpretation:
    """What a message asks for, before it is turned into tool calls."""

    steering: Side | Literal["clear", "conflict"] | None = None
    lane: str | None = None
    """A lane label, or "initial" for "back to our lane"."""
    lane_negated_only: bool = False
    lane_unspecified: bool = False
    bare_sides: list[Side] = field(default_factory=list)
    """Sides named outside any lane or obstacle context ("keep right"): used to pick where to pull over."""
    speeds: list[SpeedPhrase] = field(default_factory=list)
    bare_number: bool = False
    stop: bool = False
    stop_negated: bool = False
    pull_over: bool = False
    slow_down: bool = False
    speed_up: bool = False
    change_negated: bool = False
    emergency: Literal["yield", "resume", "hold", "oncoming"] | None = None
    resume: bool = False
    restore_all: bool = False
    question: bool = False
    conditional: bool = False


_LANE_LABEL = re.compile(r"\b(left|right|center|centre|middle|central)\b")
_BACK_TO_LANE = re.compile(
    r"\b(?:back to|return to|original|initial|usual|our own|your own|our|previous)\b[\w\s]*\blane\b"
)
# A side judged after it is named: "the right side is blocked", "dodging left is not a good idea".
_BLOCKED_AFTER = re.compile(
    r"^[\w\s]{0,30}?\b(?:is|are|looks|seems|would be)\s+(?:blocked|closed|obstructed|busy|occupied|dangerous|unsafe|"
    r"risky|forbidden|not (?:clear|safe|allowed|wise|ok|okay|good|a good idea|great)|(?:a )?bad idea)"
)
_SPEED_WORDS = re.compile(r"\b(?:speed|go|drive|slow|faster|accelerate|decelerate|km|mph|limit|cruise)\w*\b")
_EXEMPT_GONE_NEGATIONS = ("no longer", "not behind", "not there", "not around", "not coming", "any more", "anymore")


def interpret(text: str) -> Interpretation:
    """The intents of one message (no context needed)."""
    s = normalise(text)
    parts = clauses(s)
    result = Interpretation()
    first = parts[0] if parts else ""
    request_form = re.match(
        r"^(?:can|could|would|will) (?:you|we)\b|^(?:shall|should) we\b|^how about\b|^why not\b|"
        r"^(?:is|would) it (?:be )?(?:possible|ok|okay|alright|fine)\b|^do you mind\b",
        first,
    )
    result.question = bool(s.rstrip().endswith("?") and _QUESTION_START.match(first) and not request_form)
    result.conditional = bool(_CONDITIONAL_START.match(first))
    emergency_mentioned = bool(_EMERGENCY.search(s))
    message_about_obstacles = bool(_STEERING_CONTEXT.search(s)) and not _LANE_MOVE.search(s)

    steering_votes: list[Side] = []
    lane_positive: list[str] = []
    lane_negated: list[str] = []
    gone = hold = yield_ = oncoming = negated_presence = False
    for clause in parts:
        has_lane_word = bool(_LANE_MOVE.search(clause))
        steering_context = bool(_STEERING_CONTEXT.search(clause)) or bool(_INVERTED_SIDE.search(clause))
        mentions = side_mentions(clause)

        # Sides: a lane, a steering preference, or (in messages about emergency vehicles) where to pull over.
        if has_lane_word:
            labels = []
            for match in _LANE_LABEL.finditer(clause):
                label = LANE_NAMES[match.group(1)]
                if label in ("left", "right") and not any(m.side == label for m in mentions):
                    continue  # "right now", "the ambulance left"
                labels.append(label)
                negated = _is_negated(clause[: match.start()]) or bool(_BLOCKED_AFTER.match(clause[match.end():]))
                (lane_negated if negated else lane_positive).append(label)
            if not labels and _BACK_TO_LANE.search(clause):
                lane_positive.append("initial")
            elif not labels and re.search(r"\b(?:change|switch|move|merge|shift|get)\b", clause):
                result.lane_unspecified = True
        elif steering_context and mentions and not emergency_mentioned:
            steering_votes.extend(m.meaning for m in mentions)
        elif mentions and message_about_obstacles and not emergency_mentioned:
            steering_votes.extend(m.meaning for m in mentions)  # "..., left please" in a message about obstacles
        elif mentions:
            result.bare_sides.extend(m.meaning for m in mentions)
        if _CLEAR_PREFERENCE.search(clause) and not mentions:
            result.steering = "clear"

        # Speeds. In a clause about an emergency vehicle a speed describes it ("the ambulance is doing
        # 90 km/h"), it is not a request.
        if not _EMERGENCY.search(clause):
            result.speeds.extend(speed_phrases(clause))
        if _BARE_SPEED.search(clause) and not _SPEED.search(clause) and _SPEED_WORDS.search(clause):
            result.bare_number = True
        if re.search(r"\bpull over\b", clause) and not _is_negated(clause[: clause.index("pull over")]):
            result.pull_over = True
        elif (stop := _STOP.search(clause)) is not None:
            if _is_negated(clause[: stop.start()]):
                result.stop_negated = True
            else:
                result.stop = True
        for pattern, attribute in ((_SLOW, "slow_down"), (_FAST, "speed_up")):
            if match := pattern.search(clause):
                idiom = match.group(0) in ("not so fast", "too fast", "too slow")
                if not idiom and _is_negated(clause[: match.start()]):
                    result.change_negated = True
                else:
                    setattr(result, attribute, True)

        # Emergency vehicles.
        if emergency_mentioned:
            if match := _GONE.search(clause):
                if _is_negated(clause[: match.start()]) and match.group(0) not in _EXEMPT_GONE_NEGATIONS:
                    hold = True  # "it has not passed yet"
                else:
                    gone = True
            elif (ev := _EMERGENCY.search(clause)) and re.search(
                r"\b(?:no|not an?|there is no|there are no)\s*$", clause[: ev.start()]
            ):
                negated_presence = True
            elif _ONCOMING.search(clause) and (ev or _YIELD.search(clause)):
                oncoming = True
            elif _YIELD.search(clause) or (ev and (_PRESENCE.search(clause) or len(clause.split()) <= 4)):
                # A cue that it is here and needs us ("coming", "behind", "let them pass", "I hear a siren",
                # or just "Ambulance!"); a mere mention ("my sister drives an ambulance") is not one.
                yield_ = True

        # Resuming and restoring.
        if (match := _RESUME.search(clause)) and not has_lane_word and not _is_negated(clause[: match.start()]):
            result.resume = True
        if (match := _RESTORE.search(clause)) and not _is_negated(clause[: match.start()]):
            if not has_lane_word and not _CLEAR_PREFERENCE.search(clause):
                result.restore_all = True

    if emergency_mentioned:
        if gone or negated_presence:
            result.emergency = "resume"
        elif hold:
            result.emergency = "hold"
        elif yield_:
            result.emergency = "yield"
        elif oncoming:
            result.emergency = "oncoming"
    if steering_votes:
        result.steering = steering_votes[0] if len(set(steering_votes)) == 1 else "conflict"
    if lane_positive:
        result.lane = lane_positive[-1]
    elif lane_negated:
        result.lane_negated_only = True
    return result


# ---------------------------------------------------------------------------------------------- context
@dataclass(frozen=True, slots=True)
class DrivingState:
    """What the rules need to know about the specification: lane, speed, steering preference."""

    lane: str | None
    v_ref_mps: float | None
    steering: str | None

    @classmethod
    def from_attached(cls, attached: Sequence[dict[str, Any]]) -> DrivingState:
        lane = v_ref = steering = None
        for primitive in attached:
            if primitive.get("kind") == "path_tracking":
                lane, v_ref = primitive.get("lane"), primitive.get("v_ref_mps")
            elif primitive.get("kind") == "preferred_steering_direction":
                steering = primitive.get("direction")
        return cls(lane, None if v_ref is None else float(v_ref), steering)

    def describe(self) -> str:
        parts = []
        if self.lane is not None:
            parts.append(f"following the {self.lane} lane at {self.v_ref_mps:g} m/s ({self.v_ref_mps * 3.6:.0f} km/h)")
        parts.append(f"evading obstacles to the {self.steering}" if self.steering else "no preferred evasion side")
        return "; ".join(parts)


def _context(history: Sequence[Message]) -> tuple[DrivingState, DrivingState]:
    """(initial, current) driving state, from the system message and the latest successful tool result."""
    initial_attached: list[dict[str, Any]] = []
    for message in history:
        if message.role == "system" and message.data:
            initial_attached = message.data.get("initial_specification", {}).get("attached", [])
    current_attached = initial_attached
    for message in history:
        if message.role == "tool" and not message.is_error and message.data and "attached" in message.data:
            current_attached = message.data["attached"]
    return DrivingState.from_attached(initial_attached), DrivingState.from_attached(current_attached)


# ---------------------------------------------------------------------------------------------- planning
@dataclass
class Plan:
    calls: list[tuple[str, dict[str, Any]]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


class RulesBackend:
    """Deterministic stand-in for an LLM (see the module docstring). ``yield_lane`` is where it pulls over
    for emergency vehicles: "left" as in the paper (left-hand traffic); use "right" for right-hand traffic."""

    name = "rules"

    def __init__(self, yield_lane: Side = "left") -> None:
        self.yield_lane = yield_lane
        self._counter = 0

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        return self.reply(history, tools)

    async def aclose(self) -> None:
        return None

    def reply(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        if not history:
            return BackendReply("Nothing to answer.")
        last = history[-1]
        initial, current = _context(history)
        if last.role == "tool":
            return BackendReply(self._summarise_results(history, current))
        if last.role != "user":
            return BackendReply("Waiting for a message.")
        plan = self.plan(last.content, initial, current, {t.name: t for t in tools})
        calls = tuple(self._call(name, args) for name, args in plan.calls)
        if calls:
            described = ", ".join(
                f"{name}({', '.join(f'{k}={v!r}' for k, v in args.items())})" for name, args in plan.calls
            )
            text = " ".join([f"Calling {described}.", *plan.notes])
        else:
            text = " ".join([*plan.notes, f"No change to the control specification: {current.describe()}."])
        return BackendReply(text.strip(), calls)

    def _call(self, name: str, arguments: dict[str, Any]) -> ToolCall:
        self._counter += 1
        return ToolCall.of(f"rules-{self._counter}", name, arguments)

    def plan(
        self, text: str, initial: DrivingState, current: DrivingState, tools: dict[str, ToolSpec]
    ) -> Plan:
        """The tool calls for one message, given the initial and current driving state."""
        meaning = interpret(text)
        plan = Plan()
        if meaning.question:
            plan.notes.append("That is a question; I answer it without changing anything.")
            return plan
        if meaning.conditional and meaning.steering not in ("left", "right", "clear"):
            plan.notes.append("I act on what is happening now; I do not keep instructions for later situations.")
            return plan

        v_max = self._speed_limit(tools)
        explicit = self._explicit_speed(meaning, current, initial)
        wanted = explicit if explicit is not None else self._relative_speed(meaning, current, initial)
        speed, speed_note = self._clamped(wanted, v_max)
        explicit_speed, _ = self._clamped(explicit, v_max)
        if speed_note:
            plan.notes.append(speed_note)

        lane_call: tuple[str, float | None] | None = None
        if meaning.emergency == "yield" or meaning.pull_over:
            # Emergency vehicles decide lane and speed; only an explicit number changes the speed (0 otherwise).
            side = meaning.lane if meaning.lane in ("left", "right") else next(iter(meaning.bare_sides), None)
            lane_call = (side or self.yield_lane, explicit_speed if explicit_speed is not None else 0.0)
            plan.notes.append("Making way for the emergency vehicle." if meaning.emergency else "Pulling over.")
        elif meaning.emergency == "resume":
            lane_call = self._restore_lane(initial, explicit_speed)
            plan.notes.append("Resuming the original lane and speed.")
        elif meaning.emergency == "hold":
            plan.notes.append("Staying put until the emergency vehicle has passed.")
        elif meaning.emergency == "oncoming":
            plan.notes.append("The emergency vehicle is not in our direction of travel; nothing to change.")
        elif meaning.lane is not None:
            lane = initial.lane if meaning.lane == "initial" else meaning.lane
            v = speed if speed is not None else current.v_ref_mps
            if not v:  # changing lanes needs motion: a stopped car uses the original speed
                v = initial.v_ref_mps
            lane_call = (lane, v) if lane is not None else None
        elif meaning.restore_all:
            lane_call = self._restore_lane(initial, speed)
        elif meaning.resume:
            if (current.lane, current.v_ref_mps) != (initial.lane, initial.v_ref_mps) or speed is not None:
                lane_call = self._restore_lane(initial, speed)
            else:
                plan.notes.append("We are already driving as originally specified.")
        elif meaning.lane_negated_only:
            plan.notes.append("Understood which lane not to use; staying in the current lane.")

        if meaning.steering in ("left", "right"):
            plan.calls.append(("set_preferred_steering_direction", {"direction": meaning.steering}))
        elif meaning.steering == "clear":
            plan.calls.append(("clear_preferred_steering_direction", {}))
        elif meaning.steering == "conflict":
            plan.notes.append("You mentioned both sides; please tell me which one to prefer.")
        elif meaning.restore_all and initial.steering != current.steering:
            if initial.steering is None:
                plan.calls.append(("clear_preferred_steering_direction", {}))
            else:
                plan.calls.append(("set_preferred_steering_direction", {"direction": initial.steering}))

        if lane_call is not None and lane_call[1] is not None:
            lane, v = lane_call
            plan.calls.append((f"run_{lane}_lane", {"v_ref": _tidy(min(v, v_max) if v_max is not None else v)}))
        elif speed is not None and meaning.emergency is None:
            plan.calls.append(("set_reference_speed", {"v_ref": _tidy(speed)}))
        if meaning.bare_number and not meaning.speeds:
            plan.notes.append("Please give the speed with a unit (km/h, mph or m/s).")
        if meaning.change_negated and speed is None:
            plan.notes.append("Keeping the current speed.")
        if meaning.stop_negated and speed is None:
            plan.notes.append("Not stopping.")
        if meaning.lane_unspecified and meaning.lane is None:
            plan.notes.append("Which lane: left, center or right?")
        if not plan.calls and not plan.notes:
            plan.notes.append(
                "(I am a rule-based stand-in, not a language model: I understand lanes, speeds, the preferred side "
                "for evading obstacles, and emergency vehicles.)"
            )
        return plan

    def _restore_lane(self, initial: DrivingState, speed: float | None) -> tuple[str, float] | None:
        if initial.lane is None or initial.v_ref_mps is None:
            return None
        return initial.lane, speed if speed is not None else initial.v_ref_mps

    @staticmethod
    def _speed_limit(tools: dict[str, ToolSpec]) -> float | None:
        for name in ("set_reference_speed", "run_center_lane", "run_left_lane", "run_right_lane"):
            if name in tools:
                return tools[name].number_bounds("v_ref")[1]
        return None

    @staticmethod
    def _explicit_speed(meaning: Interpretation, current: DrivingState, initial: DrivingState) -> float | None:
        """A speed the message states with a unit (or "stop"), in m/s; None when it states none."""
        v_now = current.v_ref_mps if current.v_ref_mps is not None else (initial.v_ref_mps or 0.0)
        usable = [p for p in meaning.speeds if not p.negated]
        if usable:
            phrase = usable[-1]
            if phrase.mode == "set":
                return phrase.value_mps
            if phrase.mode == "by":
                slower = meaning.slow_down and not meaning.speed_up
                return v_now - phrase.value_mps if slower else v_now + phrase.value_mps
            if phrase.mode == "cap":
                return min(v_now, phrase.value_mps)
            return max(v_now, phrase.value_mps)
        if meaning.stop and not meaning.speeds:
            return 0.0
        return None

    @staticmethod
    def _relative_speed(meaning: Interpretation, current: DrivingState, initial: DrivingState) -> float | None:
        """"Slow down" / "speed up" without a number (None if the message has a number without a unit)."""
        if meaning.speeds or meaning.bare_number:
            return None
        v_now = current.v_ref_mps if current.v_ref_mps is not None else (initial.v_ref_mps or 0.0)
        if meaning.slow_down and not meaning.speed_up:
            return v_now * SLOW_DOWN_FACTOR
        if meaning.speed_up and not meaning.slow_down:
            return v_now * SPEED_UP_FACTOR if v_now > 0 else (initial.v_ref_mps or 0.0)
        return None

    @staticmethod
    def _clamped(wanted: float | None, v_max: float | None) -> tuple[float | None, str | None]:
        if wanted is None:
            return None, None
        if wanted < 0:
            return 0.0, "A speed cannot be negative; stopping instead."
        if v_max is not None and wanted > v_max:
            return v_max, f"{wanted:g} m/s is above the road speed limit; using the limit, {v_max:g} m/s."
        return wanted, None

    def _summarise_results(self, history: Sequence[Message], current: DrivingState) -> str:
        results = []
        for message in reversed(history):
            if message.role != "tool":
                break
            results.append(message)
        errors = [m for m in reversed(results) if m.is_error]
        if errors:
            detail = "; ".join(f"{m.name}: {m.content}" for m in errors)
            return f"The controller refused: {detail}. Now {current.describe()}."
        return f"Done. Now {current.describe()}."


def _tidy(value: float) -> float | int:
    """Whole numbers as ints (15, not 15.0) so transcripts read like the paper; others to 3 decimals."""
    rounded = round(float(value), 3)
    return int(rounded) if rounded == int(rounded) else rounded


def explain(text: str) -> str:
    """The interpretation of ``text`` as JSON (debugging aid)."""
    meaning = interpret(text)
    return json.dumps({k: (v if not isinstance(v, list) else [str(x) for x in v]) for k, v in vars(meaning).items()})
