"""The offline rules backend's manoeuvres (LaMPilot-Bench's commands): a following distance, overtaking, and
pulling over onto an emergency lane. Each maps to its tool of :mod:`agentic_mpc.mcp.maneuvers`, and only
where the server offers that tool; anything else goes to the general grammar (:mod:`rules_parsing`).

- following distance: "gap", "following distance" or "distance to the car ahead" with a length in metres
  (m, meters, metres, feet): absolute with "to X" / "of X" ("decrease the gap to 15 meters", "establish a
  following distance of 15 meters", "keep a 30 m gap"), relative with "by X" or "X meters closer / shorter / less / more /
  higher / longer / further" (the sign from decrease/lessen/shorten/reduce/closer/less or
  increase/expand/extend/more/higher);
- overtaking: overtake / pass / go past / go around / surpass / get ahead of the car, vehicle or lead vehicle
  in front (ahead); the side from "left"/"right" ("using the left lane"); "and come back" / "return" /
  "then merge back" returns to the lane afterwards, otherwise the passing lane is kept. Obstacles are not
  cars to overtake: "go around obstacles on the left" stays a steering preference;
- pulling over onto the emergency lane / hard shoulder / shoulder and stopping ("park", "standstill");
- choosing the way at the next junction, where the server offers ``turn_at_next_junction`` (a route through
  junctions): "turn left", "take a right", "a left turn", or a side or "straight" said with the junction
  (intersection, crossroad, junction, crossing, corner, lights): "keep to the left at the crossroad".
"""

from __future__ import annotations

import re
from typing import Any

from agentic_mpc.agent.backends.rules_parsing import normalise
from agentic_mpc.mcp.protocol import ToolName

_LENGTH = r"(\d+(?:\.\d+)?)\s*(?:m\b|meters?\b|metres?\b|feet\b|ft\b)"
_GAP_WORDS = re.compile(r"\b(?:gap|following distance|headway|distance (?:to|from|behind) the (?:car|vehicle)\b)")
_ABSOLUTE = re.compile(r"\b(?:to|of|at|is)\s+(?:be\s+)?(?:an?\s+)?(?:about\s+)?" + _LENGTH)
_LEADER = re.compile(r"\b(?:car|vehicle|truck)s?\s+(?:in front|ahead)\b|\b(?:lead|leading|front)\s+(?:car|vehicle)\b|"
                     r"\bbehind (?:the|that) (?:car|vehicle|truck)\b")
"""The car the ego follows, named: with a length, the message is about the following distance."""
_FOLLOW = re.compile(r"\bfollow(?:ing)?\b")
_MORE_LENGTH = re.compile(r"\b(\d+(?:\.\d+)?)\s+(?:more|extra)\s+(?:m\b|meters?\b|metres?\b|feet\b|ft\b)")
_ADD_LENGTH = re.compile(r"\badd(?:\s+another)?\s+" + _LENGTH)
_BACK_VERB = re.compile(r"\b(?:fall|drop|hang|pull|ease) back\b|\bback off\b")
_UP_VERB = re.compile(r"\b(?:move|close|creep|pull) up\b|\bget closer\b")
_LENGTH_PLACED = re.compile(_LENGTH + r"\s+(?:behind|between|from the|to the|back)\b|"
                            r"\b(?:keep|stay|leave|hold|maintain)\s+(?:about\s+)?" + _LENGTH)
"""An absolute gap said by where it is: "stay 15 m behind", "leave 70 m between us", "keep 20 m to the car"."""
_LENGTH_FIRST = re.compile(_LENGTH + r"\s+(?:gap|following distance|headway|distance)\b")  # "keep a 30 m gap"
_BY = re.compile(r"\bby\s+(?:about\s+)?" + _LENGTH)
_RELATIVE_WORD = re.compile(_LENGTH + r"\s+(closer|shorter|less|nearer|more|higher|longer|further|farther|larger|bigger)\b")
_SHORTER = re.compile(r"\b(?:decrease|lessen|shorten|shrink|narrow|reduce|lower|cut|tighten|close(?: up)?|closer|less|"
                      r"smaller|nearer)\b")
_LONGER = re.compile(r"\b(?:increase|expand|extend|lengthen|widen|open(?: up)?|grow|more|higher|larger|bigger|further|"
                     r"farther|longer)\b")
_FEET_TO_M = 0.3048

_OVERTAKE = re.compile(
    r"\b(?:overtake|overtaking|pass|go past|get past|drive past|surpass|go around|get around|get ahead of|"
    r"move past|go by)\b")
_CAR_AHEAD = re.compile(
    r"\b(?:car|vehicle|truck|driver)s?\b(?:\s+(?:in front|ahead))?|\b(?:lead|leading|front)\s+(?:car|vehicle)\b|"
    r"\b(?:the one|someone) (?:in front|ahead)\b")
_OBSTACLE = re.compile(r"\b(?:obstacles?|stopped|broken.down|parked|blockage)\b")
_RETURN = re.compile(r"\b(?:come back|return|go back|merge back|get back|back (?:in)?to (?:our|my|the|this) lane)\b")
_SIDE = re.compile(r"\b(left|right)\b")

_SHOULDER = re.compile(r"\b(?:emergency lane|hard shoulder|shoulder|breakdown lane)\b")

_JUNCTION = re.compile(r"\b(?:intersections?|crossroads?|junctions?|crossings?|corners?|traffic lights?|lights)\b")
_TURN = re.compile(r"\bturn(?:ing)?\s+(?:to\s+the\s+)?(left|right)\b|\b(?:take|make|hang)\s+a\s+(left|right)\b|"
                   r"\b(left|right)(?:\s+|-)turn\b")
_STRAIGHT = re.compile(r"\bstraight\b|\b(?:go|drive|continue|carry on|head)\s+(?:right\s+)?(?:on|through|across|ahead)\b")


def _metres(match: re.Match[str]) -> float:
    value = float(next(group for group in match.groups() if group is not None))
    return value * _FEET_TO_M if re.search(r"feet|ft", match.group(0)) else value


ASK_GAP = "Please give the following distance in metres."
"""Asking back for a gap: where the message gave a length, the rules did not read it (rules_understanding)."""


def maneuver_call(text: str, tools: dict[str, Any]) -> tuple[tuple[str, dict[str, Any]] | None, str | None]:
    """(the tool call, a note) for a message that asks for one of these manoeuvres; (None, None) otherwise."""
    s = " ".join(normalise(text).replace("-", " ").split())  # number words as digits, as the speeds read them
    if ToolName.SET_FOLLOWING_DISTANCE in tools and (
            _GAP_WORDS.search(s) or (_LEADER.search(s) or _FOLLOW.search(s)) and (re.search(_LENGTH, s)
                                                                            or _MORE_LENGTH.search(s))):
        return _following_distance(s)
    if ToolName.TURN_AT_NEXT_JUNCTION in tools and (_TURN.search(s) or _JUNCTION.search(s)):
        return _turn(s)
    if _SHOULDER.search(s) and ToolName.PULL_OVER in tools:
        return (str(ToolName.PULL_OVER), {}), "Pulling over onto the emergency lane and stopping."
    if _OVERTAKE.search(s) and _CAR_AHEAD.search(s) and not _OBSTACLE.search(s) and ToolName.OVERTAKE in tools:
        sides = _SIDE.findall(s)
        if len(set(sides)) != 1:
            return None, "On which side should I overtake: left or right?"
        afterwards = "return" if _RETURN.search(s) else "keep"
        return (str(ToolName.OVERTAKE), {"side": sides[0], "afterwards": afterwards}), (
            f"Overtaking the car ahead on the {sides[0]}"
            + (", then back to this lane." if afterwards == "return" else ", then staying in that lane."))
    return None, None


def _turn(s: str) -> tuple[tuple[str, dict[str, Any]] | None, str | None]:
    turn = _TURN.search(s)
    sides = {next(side for side in turn.groups() if side)} if turn else set(_SIDE.findall(s))
    if _STRAIGHT.search(s) and not turn:
        sides.add("straight")
    if len(sides) != 1:
        return None, "Which way at the junction: left, right or straight on?"
    direction = sides.pop()
    way = "straight on" if direction == "straight" else f"to the {direction}"
    return (str(ToolName.TURN_AT_NEXT_JUNCTION), {"direction": direction}), f"Taking the next junction {way}."


def _following_distance(s: str) -> tuple[tuple[str, dict[str, Any]] | None, str | None]:
    relative = _RELATIVE_WORD.search(s)
    by = _BY.search(s)
    absolute = _ABSOLUTE.search(s) or _LENGTH_FIRST.search(s)
    if relative is not None or by is not None:
        match = relative or by
        amount = _metres(match)
        longer = bool(_LONGER.search(s))
        shorter = bool(_SHORTER.search(s))
        if relative is not None:
            longer = relative.group(2) in ("more", "higher", "longer", "further", "farther", "larger", "bigger")
            shorter = not longer
        if longer == shorter:
            return None, "Should the gap grow or shrink? Please say more or less."
        change = amount if longer else -amount
        verb = "Widening" if longer else "Closing"
        return (str(ToolName.CHANGE_FOLLOWING_DISTANCE), {"change": change}), f"{verb} the gap by {amount:g} m."
    if absolute is None and (more := _MORE_LENGTH.search(s) or _ADD_LENGTH.search(s)
                             or (_BACK_VERB.search(s) or _UP_VERB.search(s)) and re.search(_LENGTH, s)):
        amount = _metres(more)  # "8 more metres", "add 10 m", "fall back 8 m", "move up 15 m"
        change = -amount if _UP_VERB.search(s) and not _BACK_VERB.search(s) else amount
        verb = "Closing" if change < 0 else "Widening"
        return (str(ToolName.CHANGE_FOLLOWING_DISTANCE), {"change": change}), f"{verb} the gap by {amount:g} m."
    absolute = absolute or _LENGTH_PLACED.search(s)
    if absolute is not None:
        gap = _metres(absolute)
        return (str(ToolName.SET_FOLLOWING_DISTANCE), {"gap": gap}), f"Keeping a {gap:g} m gap to the car ahead."
    return None, ASK_GAP
