"""The offline rules backend's vocabulary: the words and patterns it recognises (see ``rules``)."""

from __future__ import annotations

import re
from typing import Literal

Side = Literal["left", "right"]
LANE_NAMES = {"left": "left", "right": "right", "center": "center", "centre": "center", "middle": "center",
              "central": "center"}

KMH_TO_MPS = 1 / 3.6
MPH_TO_MPS = 0.44704
SLOW_DOWN_FACTOR = 0.75
SPEED_UP_FACTOR = 1.25
YIELD_ROLLING_MPS = 4.0
"""Yielding to an emergency vehicle without stopping: the speed in the yield lane (14.4 km/h)."""

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
# Making way without coming to a halt ("let them pass, but don't stop", "move over and keep rolling"): in a
# message about an emergency vehicle it asks for the yield lane at a crawl instead of a stop.
_KEEP_ROLLING = re.compile(
    r"\b(?:without (?:stopping|coming to a (?:full )?stop)|keep (?:on )?(?:rolling|moving)|no need to stop|"
    r"not (?:need to |have to )?stop(?:ping)?)\b"
)
_STOP = re.compile(r"\b(?:stop|halt|standstill|come to a (?:full )?stop|pull over|park|freeze)\b(?!\s+\w+ing\b)")
_SLOW = re.compile(
    r"\b(?:slow (?:down|it down|up)|slower|(?:go|drive|move|proceed|take it) (?:more )?slow(?:ly)?|slowly|"
    r"decelerat\w*|ease (?:off|up)|take it easy|too fast|brake|not so fast|less fast|"
    r"(?:reduce|lower|drop|cut|decrease|lessen) (?:the |your |our |current |acc |cruise )*speed)\b"
)
_FAST = re.compile(
    r"(?:\b(?:speed (?:it )?up|(?:go|drive|move|get|bit|little|lot|much|be|way) faster|accelerat\w*|hurry(?: up)?|"
    r"pick up (?:the )?(?:pace|speed)|(?:increase|raise|boost|enhance) (?:the |your |our |current |acc |cruise )*speed|"
    r"step on it|go quicker|"
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
