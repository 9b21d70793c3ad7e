"""Message understanding for the offline rules backend: normalising, clauses, sides, speeds, intents.

The grammar is described in ``agentic_mpc.agent.backends.rules``; the vocabulary is in ``rules_lexicon``.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Literal

from agentic_mpc.agent.backends.rules_lexicon import (
    _BACK_TO_LANE,
    _BARE_SPEED,
    _BLOCKED_AFTER,
    _BY,
    _CAP,
    _CLEAR_PREFERENCE,
    _COMPARISON,
    _CONDITIONAL_START,
    _EMERGENCY,
    _EXEMPT_GONE_NEGATIONS,
    _FAST,
    _FLOOR,
    _GONE,
    _INVERTED_SIDE,
    _KEEP_ROLLING,
    _LANE_LABEL,
    _LANE_MOVE,
    _LEFT_AS_VERB_BEFORE,
    _NEGATION,
    _NEUTRAL_NEGATION,
    _NOT_A_SIDE_AFTER,
    _NUMBER_WORDS,
    _ONCOMING,
    _PRESENCE,
    _QUESTION_START,
    _RESTORE,
    _RESUME,
    _RIGHT_AS_ADJECTIVE_BEFORE,
    _SIDE_AFTER,
    _SIDE_WORD,
    _SLOW,
    _SPEED,
    _SPEED_WORDS,
    _STEERING_CONTEXT,
    _STOP,
    _UNIT,
    _UNITS,
    _YIELD,
    KMH_TO_MPS,
    LANE_NAMES,
    MPH_TO_MPS,
    Side,
)


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
    sign: int = 0
    """With ``mode="by"``: +1 faster, -1 slower when the phrase itself says which ("4 m/s slower than now", "take
    6 m/s off our speed", "add 3 m/s"); 0: from the message's slow down / speed up."""


_FASTER_AFTER = re.compile(r"^\s*(?:faster|quicker|more)\b")
_SLOWER_AFTER = re.compile(r"^\s*(?:slower|less)\b|^\s*off\b")
_ADD_BEFORE = re.compile(r"\b(?:add|plus|another)\s*$")
_TAKE_BEFORE = re.compile(r"\b(?:take|knock|shave|subtract|minus)\s*$")


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
        suffix = clause[match.end():]
        sign = 0
        if mode == "set":  # a speed the phrase itself makes relative: "4 m/s slower", "add 3 m/s"
            if _FASTER_AFTER.match(suffix) or _ADD_BEFORE.search(prefix):
                mode, sign = "by", 1
            elif _SLOWER_AFTER.match(suffix) or _TAKE_BEFORE.search(prefix):
                mode, sign = "by", -1
        negated = mode == "set" and _is_negated(prefix)
        found.append(SpeedPhrase(round(mps, 3), mode, negated, match.group(0), sign))
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
    keep_rolling: bool = False
    """Make way without stopping ("let them pass, but don't stop", "keep rolling")."""
    resume: bool = False
    restore_all: bool = False
    question: bool = False
    conditional: bool = False



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
        if _KEEP_ROLLING.search(clause):
            result.keep_rolling = True
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


def explain(text: str) -> str:
    """The interpretation of ``text`` as JSON (debugging aid)."""
    meaning = interpret(text)
    return json.dumps({k: (v if not isinstance(v, list) else [str(x) for x in v]) for k, v in vars(meaning).items()})
