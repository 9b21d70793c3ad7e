"""The restore reminder (``AgentConfig.restore_reminder``, off by default): a language model that answers without a
call while the specification still differs from the initial one is told how, once, and asked again."""

from __future__ import annotations

import logging
from typing import Any

from agentic_mpc.agent.connect import read_json_resource
from agentic_mpc.agent.messages import Message
from agentic_mpc.agent.prompt import restore_note, specification_changes
from agentic_mpc.mcp.protocol import SPECIFICATION_URI


async def remind_to_restore(agent: Any, withheld: str, frozen: float | None) -> bool:
    """The restore reminder (``AgentConfig.restore_reminder``, language models only) for an answer without
    a call: if the specification differs from the initial one, record the answer (``withheld``: it does
    not enter the history, a small model repeats its last answer), append a note saying how it differs
    (a user message, ``source="agent"``) and ask once more (True): restore it if the situation that
    needed the change is over, else reply; else nothing (False). At most once per step, never after a
    successful call in the step, never in its last round."""
    if not (agent.config.restore_reminder and getattr(agent.backend, "reads_situation", True)
            and agent._client is not None and agent._initial is not None):
        return False
    current = await read_json_resource(agent._client, SPECIFICATION_URI, missing=logging.INFO)
    changes = specification_changes(agent._initial, current)
    if not changes:
        return False
    agent.transcript.record("restore_reminder", tau=agent.history.tau, sim_time_s=agent._now(frozen),
                            changes=changes, withheld_answer=withheld)
    agent._append(Message("user", restore_note(changes), source="agent", sim_time_s=agent._now(frozen)))
    return True
