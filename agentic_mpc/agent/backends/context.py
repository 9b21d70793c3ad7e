"""Keeping a chat request inside the model's context: the oldest steps of the history are left out.

The system message always stays; what goes are whole steps from the oldest on (a user message and what
followed it), replaced by one line saying how many messages were left out. The cut moves only when a request
would not fit, and then far enough that the history fits into half the context: every request between two
moves starts with the same tokens, so the model's prompt cache still holds them (a cut that moved with every
message would make the model read the whole history again each time).

Tokens are estimated from characters (``CHARS_PER_TOKEN``, on the safe side for English and JSON with the
tokenizers of the models tried here); the model's server counts exactly, but only after the request.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from agentic_mpc.agent.messages import Message

CHARS_PER_TOKEN = 3.0
"""Characters per token, low on purpose (Qwen2.5's tokenizer gives about 3.5-4 on this project's prompts)."""
PER_MESSAGE_TOKENS = 8
"""The chat template's own tokens around each message (role markers)."""


def estimate_tokens(messages: Sequence[Message]) -> int:
    """A safe estimate of the tokens ``messages`` take in a prompt."""
    chars = sum(len(m.content) + len(m.context or "") + sum(len(c.raw_arguments) + len(c.name) for c in m.tool_calls)
                for m in messages)
    return int(chars / CHARS_PER_TOKEN) + PER_MESSAGE_TOKENS * len(messages)


def _note(left_out: int) -> Message:
    return Message("user", f"({left_out} earlier messages of this conversation are left out to fit the context.)",
                   source="agent")


class ContextWindow:
    """Which part of a history goes into a request, for a limit of ``limit_tokens`` (see the module docstring)."""

    def __init__(self, limit_tokens: int | None) -> None:
        self.limit_tokens = limit_tokens
        self._cut = 1  # index of the first message kept after the system message
        self.moves = 0

    def fit(self, history: Sequence[Message]) -> list[Message]:
        messages = list(history)
        if self.limit_tokens is None or len(messages) < 2 or estimate_tokens(messages) <= self.limit_tokens:
            self._cut = 1  # it all fits (a new conversation starts here too)
            return messages
        head = messages[:1] if messages[0].role == "system" else []
        starts = [i for i in range(len(head), len(messages)) if messages[i].role == "user"]
        if self._cut not in starts:
            self._cut = starts[0] if starts else len(head)
        if estimate_tokens(head + messages[self._cut:]) > self.limit_tokens:
            later = [i for i in starts if i > self._cut]
            fitting = [i for i in later if estimate_tokens(head + messages[i:]) <= self.limit_tokens // 2]
            # else the last user message alone: the step being answered is never cut
            self._cut = fitting[0] if fitting else (later[-1] if later else self._cut)
            self.moves += 1
        kept = messages[self._cut:]
        if self._cut > len(head):
            kept = [replace(_note(self._cut - len(head)), tau=kept[0].tau)] + kept
        return head + kept
