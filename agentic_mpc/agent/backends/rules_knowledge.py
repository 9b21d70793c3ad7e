"""The rules backend looks up how to make way for an emergency vehicle where the road names a jurisdiction
and a knowledge search tool is offered (``knowledge: true``), instead of having it written in.

A yield then takes two rounds: the search (``knowledge__search_knowledge``), then the call the passage
found calls for, with the passage cited in the reply:

- a rescue lane between the left-most lane and the next (Germany): from the left-most lane keep to it, from
  any other move to the lane on the right; slow to a crawl (the rescue lane is formed at walking pace);
- pulling over to the left or the right edge and stopping (Japan, the UK; California).

Where the road also names its type (``road_type``: a motorway, a rural or an urban road, no speed signed), a
speed request is looked up the same way: the jurisdiction's limit for that type of road, read from the
passage's line for it, caps the speed asked for, and the reply cites it.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from typing import Any

from agentic_mpc.agent.messages import Message

SEARCH_TOOL = "knowledge__search_knowledge"
YIELD_QUERY = "making way for an emergency vehicle {place}"
PLACES = {"JP": "Japan", "DE": "Germany", "UK": "United Kingdom", "GB": "United Kingdom", "US-CA": "California"}


def jurisdiction_of(history: Sequence[Message]) -> str | None:
    """The road's jurisdiction as the system message recorded ``sumo://road`` (None if it names none)."""
    return _road_fact(history, "jurisdiction")


def road_type_of(history: Sequence[Message]) -> str | None:
    """The road's type where no speed is signed (``motorway``, ``rural``, ``urban``), or None."""
    return _road_fact(history, "road_type")


def _road_fact(history: Sequence[Message], key: str) -> str | None:
    for message in history:
        if message.role == "system" and message.data:
            value = (message.data.get("road") or {}).get(key)
            return value if isinstance(value, str) and value else None
    return None


def search_call(jurisdiction: str) -> tuple[str, dict[str, Any]]:
    place = PLACES.get(jurisdiction, jurisdiction)
    return SEARCH_TOOL, {"query": YIELD_QUERY.format(place=place), "k": 3, "jurisdiction": jurisdiction}


def yield_rule(result: str, jurisdiction: str) -> tuple[str, str] | None:
    """(how: 'rescue_lane', 'left' or 'right'; the citation) from a search result, preferring the passage of
    the jurisdiction's own document; None if no passage says how to make way."""
    for passage in _passages(result, jurisdiction):
        text = str(passage.get("text", "")).lower()
        if "emergency" not in text and "ambulance" not in text:
            continue
        cite = str(passage.get("cite") or passage.get("document"))
        if "rescue lane" in text:
            return "rescue_lane", cite
        left = re.search(r"pull (?:over )?to the left|left edge|to the left side", text)
        right = re.search(r"pull (?:over )?to the right|right-hand edge|right edge", text)
        if left or right:  # the rule comes first, its exceptions after ("...on a one-way road, to the right")
            first = min((m for m in (left, right) if m), key=lambda m: m.start())
            return ("left" if first is left else "right"), cite
    return None


def yield_lane(how: str, current_lane: str | None) -> tuple[str, bool]:
    """(the lane to drive, whether to stop there rather than crawl) for a rule."""
    if how == "rescue_lane":
        return ("left" if current_lane == "left" else "right"), False
    return how, True


ROAD_WORDS = {"motorway": "motorway", "rural": "rural road", "urban": "built-up area"}
"""How a speed-limit search names each road type."""
_ROAD_LINES = {
    "motorway": r"motorway|expressway|autobahn|freeway|\bhighways?:",
    "rural": r"outside built-up|single carriageway|two-lane|undivided|rural|ordinary road",
    "urban": r"built-up area|residence|business district|urban|ordinary road",
}
"""The words by which a passage's line on speed limits names each road type, in any of the jurisdictions."""


def limit_search_call(jurisdiction: str, road_type: str) -> tuple[str, dict[str, Any]]:
    place = PLACES.get(jurisdiction, jurisdiction)
    query = f"speed limit {ROAD_WORDS.get(road_type, road_type)} {place}"
    return SEARCH_TOOL, {"query": query, "k": 3, "jurisdiction": jurisdiction}


def speed_limit_rule(result: str, jurisdiction: str, road_type: str) -> tuple[float, str, str] | None:
    """(the limit in m/s, the line that states it, the citation) for ``road_type`` from a search result,
    preferring the jurisdiction's own document; None if no passage states one in m/s."""
    wanted = re.compile(_ROAD_LINES.get(road_type, re.escape(road_type)), re.IGNORECASE)
    for passage in _passages(result, jurisdiction):
        if "speed" not in f"{passage.get('section', '')} {passage.get('text', '')}".lower():
            continue
        lines = [" ".join(item.split()) for item in re.split(r"(?:^|\n)- ", str(passage.get("text", "")))]
        for line in lines:  # the first line naming the road type (the limit comes before any minimum speed)
            limit = re.search(r"\((\d+(?:\.\d+)?) m/s\)", line)
            if limit and wanted.search(line):
                return float(limit.group(1)), line, str(passage.get("cite") or passage.get("document"))
    return None


_PLACE_WORDS = {"JP": r"japan\w*", "DE": r"german\w*|autobahn", "UK": r"uk|britain|british|england|english",
                "US-CA": r"california\w*|usa|united states|america\w*"}


def question_call(question: str, jurisdiction: str | None = None) -> tuple[str, dict[str, Any]]:
    """The search for a question: among the documents of the place it names, else of the road's, else all."""
    named = [code for code, words in _PLACE_WORDS.items() if re.search(rf"\b(?:{words})\b", question.lower())]
    place = named[0] if len(named) == 1 else jurisdiction
    return SEARCH_TOOL, {"query": question[:500], "k": 3, **({"jurisdiction": place} if place else {})}


def _passages(result: str, jurisdiction: str) -> list[dict[str, Any]]:
    """A search result's passages, the jurisdiction's own documents first (none if it is not a result)."""
    try:
        passages = json.loads(result).get("passages") or []
    except (json.JSONDecodeError, AttributeError):
        return []
    prefix = jurisdiction.lower()
    return sorted(passages, key=lambda p: not str(p.get("document", "")).startswith(prefix))


def answer_from(result: str, question: str) -> str | None:
    """The sentence of the best passage that shares most words with the question, with its citation."""
    try:
        passages = json.loads(result).get("passages") or []
    except (json.JSONDecodeError, AttributeError):
        return None
    if not passages:
        return None
    best = passages[0]
    asked = _words(question) - _STOPWORDS
    text = re.sub(r"\n(?!- )", " ", str(best.get("text", "")))  # hard-wrapped lines joined; list items kept
    sentences = [s.strip(" -") for s in re.split(r"(?<=\.)\s+|\n", text) if s.strip(" -")]
    if not sentences:
        return None

    def overlap(sentence: str) -> int:
        return len(asked & _words(sentence))

    ranked = sorted(range(len(sentences)), key=lambda i: (-overlap(sentences[i]), i))[:2]
    said = " ".join(sentences[i] for i in sorted(ranked))
    return f"According to {best.get('cite') or best.get('document')}: {said}"


def _words(text: str) -> set[str]:
    """Lower-case words, a plural's s dropped (expressways ~ expressway)."""
    return {w[:-1] if len(w) > 3 and w.endswith("s") else w for w in re.findall(r"[a-z0-9]+", text.lower())}


_STOPWORDS = {"what", "is", "the", "a", "an", "on", "in", "of", "to", "how", "do", "we", "this", "for", "and", "it",
              "are", "does", "can", "our", "us", "be", "at", "with", "which", "when", "where"}
