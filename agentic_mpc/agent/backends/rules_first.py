"""Rules first, a model for the rest: a language-model backend's ``rules_first: true`` (``--agent
rules_first=true``; ``agentic-mpc eval-agent --rules-first``).

The rules backend answers every message it understands (it plans a call, or it recognises a question, a
condition, an emergency vehicle it need not act on, ...); a message it does not understand at all (small
talk, another language, wording outside its grammar) goes to the language model. The tool results of a step
go back to whoever made the calls. Measured against both backends alone in docs/llm-backends.md.
"""

from __future__ import annotations

from collections.abc import Sequence

from agentic_mpc.agent.backends.base import Backend, BackendReply, ModelUsage, ToolSpec
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.agent.backends.rules_state import driving_states
from agentic_mpc.agent.memory_rules import apply_memory
from agentic_mpc.agent.messages import Message

NOT_UNDERSTOOD = "(I am a rule-based stand-in"
"""How the rules backend's plan begins its only note when it recognised nothing in a message."""


def understood(calls: Sequence[object], notes: Sequence[str]) -> bool:
    """Whether the rules recognised something: a call, or any note but the "I am a stand-in" one."""
    return bool(calls) or any(not note.startswith(NOT_UNDERSTOOD) for note in notes)


class RulesFirst:
    """A backend: ``rules`` for what it understands, ``model`` for the rest (see the module docstring)."""

    reads_situation = True  # the model needs the situation; the rules read the message alone

    def __init__(self, rules: RulesBackend, model: Backend) -> None:
        self.rules, self.model = rules, model
        self.name = f"rules+{model.name}"
        self._model_step = False
        self.routed_to_model = 0

    async def complete(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> BackendReply:
        last = history[-1] if history else None
        if last is not None and last.role == "user":
            initial, current = driving_states(history)
            plan = apply_memory(self.rules.plan(last.content, initial, current, {t.name: t for t in tools}), last,
                                [t.name for t in tools])  # "no, the other side" is understood with memory
            self._model_step = bool(plan.not_understood) or not understood(plan.calls, plan.notes)
            self.routed_to_model += self._model_step
        if self._model_step:
            return await self.model.complete(history, tools)
        return await self.rules.complete(history, tools)

    async def warm(self, history: Sequence[Message], tools: Sequence[ToolSpec]) -> ModelUsage | None:
        """The model's prompt cache (the rules need none)."""
        warm = getattr(self.model, "warm", None)
        return None if warm is None else await warm(history, tools)

    async def aclose(self) -> None:
        await self.model.aclose()
