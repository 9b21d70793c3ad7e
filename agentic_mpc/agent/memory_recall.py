"""What the agent does with its memory (:mod:`agentic_mpc.agent.memory`) around each step.

Before a step (:meth:`MemorySession.before`) the incoming message gets what is remembered:

- for a language model, a few lines after the situation (``Message.context``): the standing preferences and
  the most similar earlier entries (a correction as "to X the call Y was wrong; they wanted Z");
- for the rules backend, the same as data (``Message.data["memory"]``: ``preferences``, ``similar``, and
  ``correcting``, the previous step's message and calls when this message corrects it), which
  :mod:`agentic_mpc.agent.memory_rules` applies.

After a step (:meth:`MemorySession.after`) it learns, from what the passenger typed (not from observation
messages):

- a **correction**: a message that says the last answer was wrong ("no, the other side", "not that lane, the
  right one", "I said left", "wrong way") and whose step made calls: the previous message, its calls (wrong)
  and this step's (right). A preference learnt from the corrected message is corrected with it;
- a **preference**: a message that states a standing wish ("always", "never", "from now on", "whenever", "I
  prefer", "I would rather", "as a rule", ...): its meaning from this step's calls (a side set, a lane) and from
  the words (a side to pull over to for emergency vehicles, a speed not to exceed), read with the rules
  backend's parser.

Every recall and every entry learnt is a transcript record (``memory_recalled``, ``memory_learned``).
"""

from __future__ import annotations

import logging
import re
import threading
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from agentic_mpc.agent.backends.rules_parsing import interpret, normalise
from agentic_mpc.agent.memory import Call, MemoryEntry, MemorySettings, MemoryStore, open_memory
from agentic_mpc.agent.messages import Message
from agentic_mpc.mcp.protocol import DIRECTION_ARGUMENT, MEMORY_URI, ToolName, lane_of_tool

logger = logging.getLogger(__name__)

_HABIT = re.compile(
    r"\b(?:always|never|in general|generally|from now on|whenever|every time|each time|usually|normally|as a rule|"
    r"by default|in (?:the )?future|next time|i (?:much |really )?prefer|i would (?:much )?rather|"
    r"i (?:really )?(?:like|love|hate|dislike)|i do not (?:like|want)|remember)\b")
_CORRECTION = re.compile(
    r"\b(?:the other (?:side|way|lane|one)|wrong (?:side|way|lane|direction)|opposite (?:side|way|lane|direction)|"
    r"other way (?:round|around))\b")
_NAY = re.compile(r"^(?:no|nope|not that(?: one| lane| side)?|wrong|i said|i meant|i mean|that is (?:wrong|not it))\b")
_EXPLICIT_SIDE = re.compile(r"(?:^(?:no|nope|wrong)\W+|\b(?:the|to the|on the|i said|i meant|i mean)\s+)(left|right)\b")


@dataclass
class PreviousStep:
    """The last step that made calls: its message, its calls, the preference learnt from it (if any)."""

    message: str
    calls: list[dict[str, Any]]
    preference: MemoryEntry | None = None


def is_correction(text: str) -> bool:
    """Whether ``text`` says the last answer took the wrong side ("no, the other side", "wrong lane", "not that
    lane, the right one", "I said left"); a bare "no, keep going" is not one."""
    s = normalise(text).strip()
    return bool(_CORRECTION.search(s)) or bool(_NAY.search(s) and explicit_side(text))


def explicit_side(text: str) -> str | None:
    """The side a correction names ("not that lane, the right one", "I said left"), if one."""
    sides = {m.group(1) for m in _EXPLICIT_SIDE.finditer(normalise(text))}
    return sides.pop() if len(sides) == 1 else None


def preference_meaning(text: str, calls: list[dict[str, Any]]) -> dict[str, Any]:
    """What a stated standing wish means: from the step's calls where they say it, else from its words."""
    if not _HABIT.search(normalise(text)):
        return {}
    meaning = interpret(text)
    found: dict[str, Any] = {}
    emergency = meaning.emergency is not None
    for call in calls:
        name, arguments = str(call["tool"]), call.get("arguments") or {}
        if name == ToolName.SET_PREFERRED_STEERING_DIRECTION and arguments.get(DIRECTION_ARGUMENT) in ("left", "right"):
            found["preferred_side"] = arguments[DIRECTION_ARGUMENT]
        elif (lane := lane_of_tool(name)) is not None:
            found["yield_side" if emergency and lane in ("left", "right") else "preferred_lane"] = lane
    if emergency:
        side = meaning.lane if meaning.lane in ("left", "right") else next(iter(meaning.bare_sides), None)
        if side is not None:
            found.setdefault("yield_side", side)
        found.pop("preferred_lane", None)
    elif meaning.steering in ("left", "right"):
        found.setdefault("preferred_side", meaning.steering)
    elif meaning.lane in ("left", "right", "center"):
        found.setdefault("preferred_lane", meaning.lane)
    caps = [p.value_mps for p in meaning.speeds if p.mode == "cap"]
    if caps:
        found["max_speed_mps"] = min(caps)
    return found


def _describe(calls: list[Call]) -> str:
    return ", ".join(call.describe() for call in calls) or "no call"


def _value(key: str, value: Any) -> str:
    return f"{value:g} m/s ({value * 3.6:.0f} km/h)" if key == "max_speed_mps" else str(value)


@dataclass
class MemorySession:
    """One agent's memory in one run (see the module docstring). Its methods never raise: memory that fails
    is a warning, the step goes on."""

    store: MemoryStore
    previous: PreviousStep | None = None
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def before(self, message: Message, transcript: Any = None, tau: int | None = None) -> Message:
        """``message`` with what is remembered (context lines for a model, ``data["memory"]`` for the rules)."""
        try:
            with self._lock:
                message, record = self._recall(message)
        except Exception:
            logger.exception("reading the memory failed; this step goes without it")
            return message
        if transcript is not None:
            transcript.record("memory_recalled", tau=tau, sim_time_s=message.sim_time_s, **record)
        return message

    def _recall(self, message: Message) -> tuple[Message, dict[str, Any]]:
        self.store.refresh()
        preferences = self.store.preferences()
        similar = self.store.similar(message.content)
        correcting = None
        if message.source == "user" and self.previous is not None and is_correction(message.content):
            correcting = {"message": self.previous.message, "calls": self.previous.calls,
                          "side": explicit_side(message.content)}
        data = {
            "profile": self.store.profile,
            "preferences": {k: {"value": v, "said": e.said, "id": e.id} for k, (v, e) in preferences.items()},
            "similar": [{"similarity": s, **e.model_dump(mode="json", exclude_none=True)} for s, e in similar],
            "correcting": correcting,
        }
        lines = [f"- standing preference: {k} = {_value(k, v)} (they said: \"{e.said}\")"
                 for k, (v, e) in preferences.items()]
        for _, entry in similar:
            if entry.kind == "correction":
                lines.append(f"- an earlier correction: to \"{entry.corrects}\" the call {_describe(entry.wrong)} was "
                             f"wrong; they wanted {_describe(entry.right)}")
            elif all(entry.said not in line for line in lines):
                lines.append(f"- they said before: \"{entry.said}\"")
        context = message.context
        if lines:
            block = (f"What this passenger told us in earlier runs (memory profile {self.store.profile!r}, "
                     f"{MEMORY_URI}); a side or speed they name now wins:\n" + "\n".join(lines))
            context = f"{context}\n\n{block}" if context else block
        record = {"profile": self.store.profile, "preferences": sorted(preferences),
                  "similar": [[e.id, s] for s, e in similar], "correcting": correcting is not None}
        return replace(message, context=context, data={**(message.data or {}), "memory": data}), record

    def after(self, message: Message, applied: list[dict[str, Any]], transcript: Any = None,
              tau: int | None = None) -> list[MemoryEntry]:
        """Learn from a step (``applied``: the calls the server accepted); the entries added."""
        try:
            with self._lock:
                added = self._learn(message, applied)
        except Exception:
            logger.exception("learning from the step failed; the memory is as it was")
            return []
        for entry in added if transcript is not None else ():
            transcript.record("memory_learned", tau=tau, sim_time_s=message.sim_time_s,
                              entry=entry.model_dump(mode="json", exclude_none=True),
                              write_error=self.store.write_error)
        return added

    def _learn(self, message: Message, applied: list[dict[str, Any]]) -> list[MemoryEntry]:
        applied = [{"tool": str(c["tool"]), "arguments": dict(c.get("arguments") or {})} for c in applied]
        added: list[MemoryEntry] = []
        learn = message.source == "user" and self.store.settings.learn
        previous = self.previous
        if learn and previous is not None and applied and applied != previous.calls and is_correction(message.content):
            added.append(self.store.add("correction", message.content, corrects=previous.message,
                                        wrong=[Call(**c) for c in previous.calls], right=[Call(**c) for c in applied]))
            if previous.preference is not None:  # the preference was read from the corrected answer: correct it
                fixed = {**previous.preference.means.items(), **preference_meaning(previous.message, applied)}
                self.store.replace(previous.preference, means=fixed)
                self.store.save()
        elif learn and (meaning := preference_meaning(message.content, applied)):
            added.append(self.store.add("preference", message.content, means=meaning))
        if applied:
            preference = next((e for e in added if e.kind == "preference"), None)
            self.previous = PreviousStep(message.content, applied, preference)
        return added

    def to_json(self) -> dict[str, Any]:
        with self._lock:
            return self.store.to_json()


def run_name(transcript_path: Path | None) -> str:
    """The run an entry came from: the run directory's name, else the time."""
    if transcript_path is not None and transcript_path.parent.name:
        return transcript_path.parent.name
    return "run-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")


def open_session(settings: MemorySettings | None, transcript_path: Path | None = None
                 ) -> tuple[MemorySession | None, str | None]:
    """The agent's memory (None without ``memory:`` settings), and the problem ``on_error: ignore`` passed
    over; a file that cannot be used with ``on_error: fail`` raises :class:`MemoryFileError`."""
    store, problem = open_memory(settings, run_name(transcript_path))
    return (MemorySession(store) if store is not None else None), problem


def memory_json(session: MemorySession | None, problem: str | None) -> dict[str, Any] | None:
    """What ``agent://memory`` shows: the profile's file, preferences and entries; the problem that left the
    run without memory; None without memory."""
    if session is not None:
        return session.to_json()
    return {"profile": None, "entries": [], "error": problem} if problem else None
