"""Knowledge brought to the model: before a language model answers a message, the passages that bear on it
and on the situation (the road's jurisdiction and road type, an emergency vehicle in the message or in the
situation) are looked up on the knowledge server the agent hosts (its ``search_knowledge`` tool, over MCP)
and go into that step's context, each cut to its best-matching sentences and tagged with its document id to
cite. The search tool stays offered for what retrieval missed.

Which place's rules: the one the message names ("in Germany", "a British motorway"), else the road's
``jurisdiction`` (``sumo://road``); the car's manual is any place's. One passage for the message, cut to its
three best-matching sentences; for a message that needs none, the rule for making way when the situation
lists an emergency vehicle (a question about the car with an ambulance behind got the rule for making way
too, and a small model then acted on it). Nothing is retrieved for a message that asks nothing of rules or the car (a side to
evade, small talk): each passage costs a small model on one CPU thread about 3 s to read.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.messages import Message

logger = logging.getLogger(__name__)

SEARCH_SUFFIX = "__search_knowledge"
MAX_PASSAGES = 1
SENTENCES_PER_PASSAGE = 3
MAX_SENTENCE_CHARS = 240

PLACES: dict[str, tuple[str, ...]] = {
    "JP": ("japan", "japanese"),
    "DE": ("germany", "german", "autobahn", "deutschland"),
    "UK": ("uk", "britain", "british", "england", "english", "highway code"),
    "US-CA": ("california", "californian"),
}
"""The jurisdictions of the shipped documents and the words that name them in a message."""

_TOPICS = (
    "limit", "speed", "km/h", "mph", "m/s", "fast", "slow", "ambulance", "fire", "police", "siren", "emergency",
    "rescue", "way", "yield", "overtak", "pass", "follow", "distance", "gap", "second", "shoulder", "stop",
    "lane", "rule", "law", "allowed", "may i", "must", "legal", "car", "long", "wide", "heavy", "weigh",
    "mass", "brake", "braking", "top speed", "length", "width",
)
_WORD = re.compile(r"[A-Za-z0-9\u00C0-\u024F]+")
_STOP = frozenset(["a", "an", "the", "is", "are", "we", "us", "our", "to", "of", "on", "in", "at", "for", "do", "does", "you", "i", "it", "this", "that", "what", "how", "which", "may", "can", "be", "with", "by", "and", "or", "as", "from", "please", "let", "s", "there", "its"])
SPEED_WORDS = re.compile(r"speed|km/h|mph|m/s|fast|slow|limit|quick|hurry|\d", re.IGNORECASE)
_EMERGENCY = re.compile(r"ambulance|fire (engine|truck)|police|siren|emergency|rettung|krankenwagen|救急",
                        re.IGNORECASE)


@dataclass(frozen=True)
class Retrieved:
    """A passage brought into the context: its document id (what the model cites), section and sentences."""

    document: str
    section: str
    text: str

    def line(self) -> str:
        return f"[{self.document}] {self.section}: {self.text}"


def named_place(message: str) -> str | None:
    """The jurisdiction a message names, or None."""
    lowered = f" {message.lower()} "
    for code, words in PLACES.items():
        if any(re.search(rf"\b{re.escape(word)}\b", lowered) for word in words):
            return code
    return None


def wants_knowledge(message: str, emergency: bool = True) -> bool:
    """Whether a message may need a rule or the car's manual (``emergency``: an emergency vehicle it names
    counts; not when the situation shows that none needs way, :func:`emergency_needs_way`)."""
    lowered = message.lower()
    if named_place(message) or (emergency and _EMERGENCY.search(message)) or _asks(message):
        return True
    return any(topic in lowered for topic in _TOPICS) and bool(re.search(r"\d|limit|rule|law|allowed", lowered))


def _asks(message: str) -> bool:
    """A question, not a request put as one ("let's pass on the right, shall we?" brought a passage on
    overtaking that a small model then cited): the rules' reading (backends/rules_parsing.py)."""
    if "?" not in message:
        return False
    from agentic_mpc.agent.backends.rules_parsing import interpret

    return interpret(message).question


def retrieval_query(message: str, road: dict[str, Any] | None, situation: str | None = None) -> str:
    """What to search for the message: its words, 'speed limit' and the road type when it asks about speed,
    'emergency vehicle make way' when it mentions one (unless the situation shows that none needs way)."""
    words = [message]
    lowered = message.lower()
    road_type = str((road or {}).get("road_type") or "")
    if re.search(r"speed|km/h|mph|m/s|fast|slow|limit|\d", lowered):
        words.append(f"speed limit {road_type} {'expressway' if road_type == 'motorway' else ''}".strip())
    if _EMERGENCY.search(message) and emergency_needs_way(situation) is not False:
        words.append("emergency vehicle make way")
    return " ".join(words)


def emergency_needs_way(situation: str | None) -> bool | None:
    """Whether an emergency vehicle of the situation needs way from us: one behind or beside us (True), none
    or only ones ahead of us, past us (False), no situation read (None: the message is all there is). The
    rule for making way bears on a message about an emergency vehicle only while one needs way: "the
    ambulance is gone" with that rule beside it was answered "No need to change." by a small model."""
    if not situation or "emergency vehicle" not in situation:
        return None
    lines = re.findall(r"^- emergency vehicle \S+ '.*$", situation, flags=re.M)
    return any("ahead of us" not in line for line in lines)


def _terms(text: str) -> set[str]:
    return {w.lower()[:5] for w in _WORD.findall(text) if w.lower() not in _STOP}


def best_sentences(text: str, query: str, keep: int = SENTENCES_PER_PASSAGE) -> str:
    """The ``keep`` sentences (or list items) of ``text`` sharing most words with ``query``, in their order."""
    parts = [p.strip(" -") for p in re.split(r"(?<=[.!?])\s+|\n(?=- )", text.replace("\n  ", " ")) if p.strip(" -")]
    wanted = _terms(query)
    scored = sorted(range(len(parts)), key=lambda i: (-len(_terms(parts[i]) & wanted), i))[:keep]
    chosen = [" ".join(parts[i].split())[:MAX_SENTENCE_CHARS] for i in sorted(scored)]
    return " ".join(chosen)


def from_search_result(result: str, query: str, limit: int = MAX_PASSAGES) -> list[Retrieved]:
    """The passages of a ``search_knowledge`` answer (its JSON text), cut to their best sentences."""
    try:
        passages = json.loads(result).get("passages") or []
    except (ValueError, AttributeError):
        return []
    found = []
    for passage in passages[:limit]:
        if isinstance(passage, dict) and isinstance(passage.get("document"), str):
            found.append(Retrieved(passage["document"], str(passage.get("section") or ""),
                                   best_sentences(str(passage.get("text") or ""), query)))
    return found


def compact_search_result(result: str, limit: int = 2) -> str:
    """A ``search_knowledge`` answer as a small model reads it: its best ``limit`` passages, each its best
    sentences for the query and its [id] (some 150 tokens instead of 1,200: Qwen 1.5B took 40 s to read the
    whole answer on one thread); an answer that is not the search's JSON as it is."""
    try:
        answer = json.loads(result)
        query, passages = str(answer.get("query") or ""), answer.get("passages") or []
    except (ValueError, AttributeError):
        return result
    found = from_search_result(result, query, limit)
    sources = [(p.get("sources") or [""])[0] if isinstance(p, dict) else "" for p in passages]
    return "\n".join(f"- {item.line()}" + (f" (source: {source.split(';')[0][:100]})" if source else "")
                     for item, source in zip(found, sources, strict=False)) if found else "(nothing found)"


def context_block(found: Sequence[Retrieved]) -> str | None:
    """The lines that go before the passenger's message (None: nothing found)."""
    if not found:
        return None
    return ("Rules and facts that may apply (cite the [id] you use):\n"
            + "\n".join(f"- {item.line()}" for item in found))


Search = Callable[[str, dict[str, Any]], Awaitable[str | None]]


async def retrieve(search: Search, tool_name: str, message: str, road: dict[str, Any] | None,
                   situation: str | None = None) -> list[Retrieved]:
    """The passage for ``message``, or, if it needs none and an emergency vehicle is near, the rule for making
    way: searches of the knowledge server through
    ``search(tool_name, arguments)`` (the agent's host), limited to the place the message names or the road's."""
    queries = []
    if wants_knowledge(message, emergency=emergency_needs_way(situation) is not False):
        queries.append(retrieval_query(message, road, situation))
    if emergency_needs_way(situation) and not queries:  # a message of its own topic gets its own passage only
        queries.append("emergency vehicle approaching make way pull over")
    place = named_place(message) or (road or {}).get("jurisdiction")
    found: list[Retrieved] = []
    for query in queries:
        arguments: dict[str, Any] = {"query": query[:500], "k": MAX_PASSAGES}
        if isinstance(place, str) and re.fullmatch(r"[A-Za-z]{2}(-[A-Za-z0-9]{1,3})?", place):
            arguments["jurisdiction"] = place
        result = await search(tool_name, arguments)
        for item in [] if result is None else from_search_result(result, query):
            if (item.document, item.section) not in {(f.document, f.section) for f in found}:
                found.append(item)
    return found


def search_tool(tool_names: Sequence[str]) -> str | None:
    """The knowledge server's search tool among the agent's tools (None: no knowledge server)."""
    return next((name for name in tool_names if name.endswith(SEARCH_SUFFIX)), None)


async def retrieved_message(message: Message, host: Any, tools: Sequence[ToolSpec],
                            road: dict[str, Any] | None) -> Message:
    """``message`` with the passages retrieved for it after its context and their ids in ``data["retrieved"]``
    (unchanged without a knowledge server or when nothing bears on it). ``host`` runs the search (the
    agent's :class:`~agentic_mpc.agent.hosting.ServerHost`); a failed search retrieves nothing."""
    name = search_tool([t.name for t in tools])
    if name is None or message.source == "agent":
        return message

    async def search(tool: str, arguments: dict[str, Any]) -> str | None:
        try:
            result = await host.call_tool(tool, arguments)
        except Exception as error:  # noqa: BLE001 - the step goes on without passages
            logger.warning("knowledge retrieval failed: %r", error)
            return None
        if getattr(result, "is_error", False):
            return None
        return "".join(getattr(part, "text", "") for part in getattr(result, "content", []) or [])

    found = await retrieve(search, name, message.content, road, message.context)
    block, data = context_block(found), dict(message.data or {})
    limit = await law_limit(search, name, road)
    if limit is not None:  # the tool layer keeps to it (toolset.converted); said where the message is on speed
        mps, line, cite = limit
        where = f"a {road.get('road_type')} in {road.get('jurisdiction')} [{cite}]" if road else f"[{cite}]"
        data["law_limit"] = {"mps": mps, "why": where}
        if SPEED_WORDS.search(message.content):
            said = (f"The law's speed limit on this road: {mps:g} m/s ({mps * 3.6:.0f} km/h), {where}; a faster "
                    "speed asked for is set to it.")
            block = "\n\n".join(filter(None, [block, said]))
            found = [*found, Retrieved(cite, "", line)] if cite not in [f.document for f in found] else found
    if block is None:
        return replace(message, data=data) if data != (message.data or {}) else message
    return replace(message, context="\n\n".join(filter(None, [message.context, block])),
                   data={**data, "retrieved": [item.document for item in found]})


async def law_limit(search: Search, tool_name: str, road: dict[str, Any] | None) -> tuple[float, str, str] | None:
    """(m/s, the line that states it, its document) the road's jurisdiction sets for its type of road where no
    speed is signed (``sumo://road``'s ``jurisdiction`` and ``road_type``), read as the rules read it
    (backends/rules_knowledge.py); None for a road without them or a search that finds no such line."""
    from agentic_mpc.agent.backends.rules_knowledge import limit_search_call, speed_limit_rule

    jurisdiction, road_type = (road or {}).get("jurisdiction"), (road or {}).get("road_type")
    if not (isinstance(jurisdiction, str) and jurisdiction and isinstance(road_type, str) and road_type):
        return None
    _, arguments = limit_search_call(jurisdiction, road_type)
    result = await search(tool_name, arguments)
    found = None if result is None else speed_limit_rule(result, jurisdiction, road_type)
    if found is None:
        return None
    mps, line, cite = found
    try:  # the document's id to cite, not the citation's full text
        passages = json.loads(result).get("passages") or []
    except (ValueError, AttributeError):
        passages = []
    document = next((str(p["document"]) for p in passages if isinstance(p, dict) and p.get("document")
                     and line[:40] in " ".join(str(p.get("text", "")).split())), cite)
    return mps, line, document
