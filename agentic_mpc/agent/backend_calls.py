"""Asking the backend for the next answer of a step: bounded retries, the step's budget, what it cost.

A step has a budget (``step_budget_s`` of wall time, ``step_budget_tokens`` of model tokens, the prompt
tokens the model processed plus those it generated, as its server reports them): an answer is waited for at
most until the time runs out, and no answer is asked for once either is spent. Then the step ends
(``budget``); what it already changed stands, nothing else does: the car keeps its last valid specification.

A model server that lost its prompt cache (restarted, or another client's prompt took its slot) reads the
whole prompt again: an answer that took fewer tokens from the cache than the system message has is recorded
(``prompt_cache_lost``, with the tokens it read) and logged; the step goes on, within its budget.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from agentic_mpc.agent.backends.base import Backend, BackendError, BackendReply, ModelUsage, ToolSpec
from agentic_mpc.agent.messages import Message
from agentic_mpc.agent.transcript import Transcript

logger = logging.getLogger("agentic_mpc.agent.agent")


class BudgetSpent(BackendError):
    """The step's time or token budget ran out before the backend answered."""


@dataclass
class StepUsage:
    """What a step's answers cost the model, summed (times None when the server reported none)."""

    answers: int = 0
    prompt_tokens: int = 0
    cached_tokens: int = 0
    generated_tokens: int = 0
    model_s: float | None = None

    def add(self, usage: ModelUsage | None) -> None:
        self.answers += 1
        if usage is None:
            return
        self.prompt_tokens += usage.prompt_tokens
        self.cached_tokens += usage.cached_tokens
        self.generated_tokens += usage.generated_tokens
        if usage.model_s is not None:
            self.model_s = (self.model_s or 0.0) + usage.model_s

    @property
    def tokens(self) -> int:
        return self.prompt_tokens + self.generated_tokens

    def describe(self) -> dict[str, Any]:
        return {"answers": self.answers, "prompt_tokens": self.prompt_tokens, "cached_tokens": self.cached_tokens,
                "generated_tokens": self.generated_tokens,
                "model_s": None if self.model_s is None else round(self.model_s, 3)}


class StepBudget:
    """The budget of one step, from when it started (see the module docstring)."""

    def __init__(self, seconds: float | None, tokens: int | None) -> None:
        self.seconds, self.tokens = seconds, tokens
        self.started = time.perf_counter()

    def elapsed_s(self) -> float:
        return time.perf_counter() - self.started

    def remaining_s(self) -> float:
        return math.inf if self.seconds is None else self.seconds - self.elapsed_s()

    def spent(self, usage: StepUsage) -> str | None:
        """Why no further answer may be asked for, or None."""
        if self.remaining_s() <= 0.0:
            return f"the step's time budget of {self.seconds:g} s is spent ({self.elapsed_s():.1f} s)"
        if self.tokens is not None and usage.tokens >= self.tokens:
            return f"the step's budget of {self.tokens} model tokens is spent ({usage.tokens})"
        return None


async def complete(backend: Backend, history: Sequence[Message], tools: Sequence[ToolSpec], config: Any,
                   transcript: Transcript, now: Callable[[], float | None], budget: StepBudget,
                   system_tokens: int | None = None) -> BackendReply:
    """The backend's next answer: ``config.backend_attempts`` tries of at most ``config.backend_timeout_s``
    each (and never past the step's time budget: then :class:`BudgetSpent`); :class:`BackendError` if none.
    ``system_tokens``: the system message's tokens (from the warm-up), to notice a lost prompt cache."""
    last_error: BaseException | None = None
    for attempt in range(1, config.backend_attempts + 1):
        wait_s = min(config.backend_timeout_s, budget.remaining_s())
        try:
            reply = await asyncio.wait_for(backend.complete(history, tools), wait_s)
            usage = reply.usage
            if system_tokens and usage is not None and usage.cached_tokens < system_tokens // 2:
                logger.warning("the model's server had lost its prompt cache: it read %d prompt tokens again",
                               usage.prompt_tokens)
                transcript.record("prompt_cache_lost", tau=len(history) - 1, sim_time_s=now(),
                                  prompt_tokens=usage.prompt_tokens, cached_tokens=usage.cached_tokens,
                                  system_tokens=system_tokens)
            return reply
        except (BackendError, TimeoutError) as error:
            last_error = error
            detail = str(error) or f"no answer within {wait_s:g} s"
        except Exception as error:  # a backend bug must not kill the agent either
            last_error = error
            detail = f"unexpected backend failure: {error!r}"
        if budget.remaining_s() <= 0.0:
            raise BudgetSpent(f"the step's time budget of {budget.seconds:g} s ran out waiting for an answer "
                              f"({detail})")
        logger.warning("backend %s failed (attempt %d/%d): %s", backend.name, attempt, config.backend_attempts, detail)
        transcript.record("backend_error", tau=len(history) - 1, sim_time_s=now(), backend=backend.name,
                          attempt=attempt, error=detail)
        if attempt < config.backend_attempts:
            await asyncio.sleep(min(config.retry_backoff_s * attempt, max(0.0, budget.remaining_s())))
    raise BackendError(
        f"backend {backend.name} gave no usable answer after {config.backend_attempts} attempts: "
        f"{str(last_error) or type(last_error).__name__}"
    )


async def warm_up(backend: Backend, system: Sequence[Message], tools: Sequence[ToolSpec], config: Any,
                  transcript: Transcript, now: Callable[[], float | None]) -> int | None:
    """Have a backend with a prompt cache (``warm``: the chat backends) read the system message before the
    first message arrives, so that the first message costs only its own tokens. Logged and recorded
    (``warm_up``); a failure is not fatal: the first message reads the prompt instead. Returns the system
    message's tokens as the server counted them (None: unknown)."""
    warm = getattr(backend, "warm", None)
    if warm is None:
        return None
    started = time.perf_counter()
    try:
        usage = await asyncio.wait_for(warm(system, tools), config.warm_up_timeout_s)
    except Exception as error:  # noqa: BLE001 - see the docstring
        detail = str(error) or type(error).__name__
        logger.warning("warming the model's prompt cache failed: %s", detail)
        transcript.record("warm_up", tau=0, sim_time_s=now(), error=detail)
        return None
    wall_s = time.perf_counter() - started
    prompt_tokens = None if usage is None else usage.prompt_tokens
    logger.info("the model read the system message before the first message: %s new prompt tokens in %.1f s",
                "?" if prompt_tokens is None else prompt_tokens, wall_s)
    transcript.record("warm_up", tau=0, sim_time_s=now(), wall_s=round(wall_s, 3), prompt_tokens=prompt_tokens,
                      cached_tokens=None if usage is None else usage.cached_tokens,
                      model_s=None if usage is None or usage.model_s is None else round(usage.model_s, 3))
    return None if usage is None else usage.prompt_tokens + usage.cached_tokens
