"""What the offline rules did not understand: the parts of a message that ask for something no rule reads.

The rules answer a message only when every part of it that asks for something is understood: a confident call
made from half a sentence ("stay 20 m behind the car ahead" read as nothing, "go 4 m/s faster than now" read as
4 m/s) is worse than no call, because with ``rules_first`` a language model would never see the message. So
before planning, each clause of the message is checked:

- a clause *asks for something* if it has a driving verb or noun (go, keep, stay, follow, gap, lane, faster, ...)
  or a number;
- it is *understood* if one of the grammar's readings fires in it (a side, a lane, a speed with its unit, stop,
  slow down, an emergency-vehicle cue, resume, restore, a following distance, an overtake, pulling over), and
  every number in it is read (a speed's or a length's);
- a speed or a length read as a target ("7 m/s") in a clause that also says it is a change ("speed up",
  "another", "from here") without a word that makes it a target ("to", "at", "of") is ambiguous: not understood;
- a question or a condition about the future is answered as such (no call), so it counts as understood.

A message in another language is not read at all: the rules say so (with ``rules_first``, the model answers).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

from agentic_mpc.agent.backends import rules_maneuvers
from agentic_mpc.agent.backends.rules_lexicon import (
    _BACK_TO_LANE,
    _BARE_SPEED,
    _CLEAR_PREFERENCE,
    _EMERGENCY,
    _FAST,
    _GONE,
    _KEEP_ROLLING,
    _LANE_LABEL,
    _LANE_MOVE,
    _ONCOMING,
    _PRESENCE,
    _RESTORE,
    _RESUME,
    _SLOW,
    _SPEED,
    _STEERING_CONTEXT,
    _STOP,
    _YIELD,
)
from agentic_mpc.agent.backends.rules_parsing import clauses, normalise, side_mentions, speed_phrases

ASKING = re.compile(
    r"\b(?:go|drive|get|move|change|switch|shift|merge|keep|stay|hold|maintain|follow|tail|trail|slow\w*|speed\w*|"
    r"accelerat\w*|decelerat\w*|brake|stop|halt|park|pull|overtake|pass|turn|make|let|yield|give way|increase|"
    r"decrease|reduce|raise|lower|set|adjust|close|open|widen|shorten|lengthen|return|avoid|dodge|steer|swerve|"
    r"evade|faster|slower|quicker|distance|gap|space|room|lane|exit|take|head|cruise|hurry|drop|bump|"
    r"cut|ease|push|floor|step on|give|leave|put|bring|fall|hang|add|make|use)\b")
"""Words that ask the car to do something: a clause with one (or with a number) must be understood."""

_NUMBER = re.compile(r"\b\d+(?:\.\d+)?\b")  # not the digit of an id ("amb0")
_LENGTH = re.compile(rules_maneuvers._LENGTH)
_TIME = re.compile(r"\bt\s*=\s*\d+(?:\.\d+)?|\b\d+(?:\.\d+)?\s*(?:s|sec|secs|seconds?)\b")
"""A time (an observation's stamp, "in 5 seconds"): a description, not a request."""
_LANE_NUMBER = re.compile(r"\blanes?\s+(?:number\s+)?\d+\b|\b\d+(?:st|nd|rd|th)\s+lane\b|\b\d+\s+lanes?\b")

ENGLISH = re.compile(
    r"\b(?:the|a|an|to|of|and|or|is|are|be|we|us|you|i|it|please|on|in|at|by|for|from|with|our|my|your|this|that|"
    r"car|lane|left|right|speed|go|slow|fast|stop|let|can|could|would|do|not|no|yes|ok|okay|thanks?|hi|hello|what|"
    r"which|how|why|there|here|now|up|down|behind|ahead|front|ambulance|obstacles?|km|mph|m/s)\b")
"""Words of English common enough that a message without any of them is not English."""
_LETTERS = re.compile(r"[^\W\d_]", re.UNICODE)


def not_english(text: str) -> bool:
    """Whether ``text`` is in a language the rules do not read: mostly letters outside the Latin alphabet, or
    three words or more of which none is a common English word, a word of the grammar or a unit it reads."""
    letters = _LETTERS.findall(text)
    if letters and sum(1 for c in letters if ord(c) > 0x24F) > 0.3 * len(letters):
        return True
    s = text.lower()
    words = re.findall(r"[^\W\d_]+", s)
    known = ENGLISH.search(s) or ASKING.search(s) or _SPEED.search(s) or _LENGTH.search(s)
    return len(words) >= 3 and not known


CHANGE_CUE = re.compile(r"\b(?:speed up|slow down|faster|slower|quicker|more|less|another|further|farther|extra|"
                        r"from here|from now|from what|than now|than we|than before|away|closer|nearer|lower|"
                        r"reduce|drop|brake|cut|raise|increase|add|take|knock|back)\b")
"""Words that make a number a change rather than a target."""
TARGET_BEFORE = re.compile(r"\b(?:to|at|of|is|be|say|about|around|exactly|only|just)\s+(?:an?\s+)?$")


def _ambiguous(clause: str, message: str, tools: dict[str, Any]) -> bool:
    """A number whose role the clause leaves open: a target ("7 m/s") in a clause that also says it is a change
    ("speed up", "another", "lower"); a change "by 4 m/s" that says neither faster nor slower; a change of the gap
    said only by a verb ("hang back") where the length is placed as a target ("so there are 70 m to the car")."""
    phrases = speed_phrases(clause)
    if any(p.mode == "by" and not p.sign for p in phrases) and not (_SLOW.search(message) or _FAST.search(message)):
        return True
    call, _ = rules_maneuvers.maneuver_call(clause, tools)
    m = rules_maneuvers
    if call is not None and call[0] == "change_following_distance" and (
            m._LENGTH_PLACED.search(clause) or m._ABSOLUTE.search(clause)) and not (
            m._RELATIVE_WORD.search(clause) or m._BY.search(clause) or m._MORE_LENGTH.search(clause)
            or m._ADD_LENGTH.search(clause)):
        return True
    if not CHANGE_CUE.search(clause):
        return False
    targets = [match for match in _SPEED.finditer(clause)
               if not any(p.mode != "set" for p in phrases if p.text == match.group(0))]
    if call is not None and call[0] == "set_following_distance":
        targets += list(_LENGTH.finditer(clause))
    return any(not TARGET_BEFORE.search(clause[: match.start()]) for match in targets)


def _recognised(clause: str, emergency_message: bool, about_obstacles: bool, sides_said: bool,
                tools: dict[str, Any]) -> bool:
    """Whether one of the grammar's readings fires in ``clause`` (the readings of ``rules_parsing.interpret``
    and ``rules_maneuvers.maneuver_call``, each tested on the clause alone; ``sides_said``: the message names a
    side somewhere, which a clause about obstacles refers to: "avoid obstacles, but not from the right")."""
    mentions = side_mentions(clause)
    if sides_said and _STEERING_CONTEXT.search(clause):
        return True
    lane_word = bool(_LANE_MOVE.search(clause))
    if lane_word and (_LANE_LABEL.search(clause) or _BACK_TO_LANE.search(clause)):
        return True
    if mentions and (lane_word or _STEERING_CONTEXT.search(clause) or about_obstacles or emergency_message):
        return True
    if any(p.search(clause) for p in (_SPEED, _CLEAR_PREFERENCE, _KEEP_ROLLING, _STOP, _SLOW, _FAST, _RESUME,
                                      _RESTORE)):
        return True
    if emergency_message and any(p.search(clause) for p in (_EMERGENCY, _GONE, _YIELD, _PRESENCE, _ONCOMING)):
        return True
    call, note = rules_maneuvers.maneuver_call(clause, tools)
    if call is None and note == rules_maneuvers.ASK_GAP and _LENGTH.search(clause):
        return False  # asking for a length the clause gives: its wording was not read ("the gap should be 15 m")
    return call is not None or note is not None  # a manoeuvre it reads, or asks back about (which side?)


def _unread_numbers(clause: str) -> list[str]:
    """Numbers in ``clause`` that no speed (with its unit), length or lane number reads."""
    read = [m.span() for pattern in (_SPEED, _LENGTH, rules_maneuvers._MORE_LENGTH, _LANE_NUMBER, _TIME)
            for m in pattern.finditer(clause)]
    return [m.group(0) for m in _NUMBER.finditer(clause)
            if not any(start <= m.start() < end for start, end in read)]


def not_understood(text: str, tools: dict[str, Any], answered_as_such: bool = False) -> list[str]:
    """The parts of ``text`` that ask for something the rules do not read (empty: every part is understood).
    ``answered_as_such``: the message is a question or a condition, which the rules answer without a call."""
    if not_english(text):
        return [text.strip()]
    if answered_as_such:
        return []
    s = normalise(text)
    parts = clauses(s)
    emergency_message = bool(_EMERGENCY.search(s))
    about_obstacles = bool(_STEERING_CONTEXT.search(s))
    sides_said = any(side_mentions(clause) for clause in parts)
    # a manoeuvre read from the whole message covers its later clauses ("..., and then come back")
    manoeuvre = rules_maneuvers.maneuver_call(text, tools)[0] is not None
    missed = []
    for clause in parts:
        unread = _unread_numbers(clause)
        if _BARE_SPEED.search(clause) and not _SPEED.search(clause):
            unread = []  # a speed without its unit: the rules ask for the unit
        asks = bool(ASKING.search(clause)) or bool(unread)
        if manoeuvre and rules_maneuvers._RETURN.search(clause) and not unread:
            continue
        if asks and (unread or not _recognised(clause, emergency_message, about_obstacles, sides_said, tools)
                     or _ambiguous(clause, s, tools)):
            missed.append(clause)
    return missed


def describe(missed: Iterable[str], english: bool = True) -> str:
    """The reply's sentence for what was not understood."""
    if not english:
        return ("I only read English, so I did not act on this message. (I am a rule-based stand-in, not a language "
                "model.)")
    quoted = "; ".join(f"\"{part}\"" for part in missed)
    return (f"I did not understand {quoted}, so I changed nothing. I understand lanes, speeds with units, "
            "following distances in metres, overtaking, the preferred side for obstacles and emergency vehicles.")
