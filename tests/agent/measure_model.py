"""How a GGUF model's answers parse: ``python tests/agent/measure_model.py MODEL.gguf [--tool-mode native]``.

Not a test and not the accuracy suite (that is ``agentic-mpc eval-agent``'s job): each of 12 passenger
messages is answered once from ``[system, user]`` (the system message the agent builds at the paper's
Scenario 1 start) through the ``llamacpp`` backend, and every answer is counted as a valid call, a call with
arguments outside the schema, an unparsed call, or a reply; with the latency. The numbers in
docs/llm-backends.md come from here (one thread, temperature 0, ``max_tokens`` 160).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from agentic_mpc.agent import Agent, Message
from agentic_mpc.agent.backends import make_backend
from agentic_mpc.agent.backends.rules import RulesBackend
from agentic_mpc.mcp.protocol import validate_arguments
from tests.agent.conftest import paper_start_config, plain_loop

MESSAGES = (
    "Let's try to avoid obstacles from the right, shall we?",
    "Let's try to avoid obstacles from the left, shall we?",
    "An ambulance is coming behind us. We'd better let them pass.",
    "Thank you. The ambulance is gone.",
    "Please slow down to 36 km/h.",
    "Don't pass obstacles on the left.",
    "What a nice day!",
    "Could you drive a bit faster, say 20 m/s?",
    "Move to the right lane please.",
    "Forget the steering preference, evade however you like.",
    "There's a fire truck with sirens behind us.",
    "Stop the car in the center lane.",
)


async def measure(backend, system: Message, tools) -> None:
    by_name = {t.name: t for t in tools}
    counts: Counter[str] = Counter()
    latencies = []
    for text in MESSAGES:
        started = time.perf_counter()
        reply = await backend.complete([system, Message("user", text, tau=1)], tools)
        latencies.append(time.perf_counter() - started)
        shown = []
        for call in reply.tool_calls:
            if call.error is not None or call.name not in by_name:
                counts["unparsed"] += 1
                shown.append(f"UNPARSED {call.error}")
                continue
            try:
                validate_arguments(call.name, by_name[call.name].input_schema, call.arguments)
                counts["valid call"] += 1
            except ValueError:
                counts["arguments outside the schema"] += 1
            shown.append(f"{call.name}({call.arguments})")
        if not reply.tool_calls:
            counts["reply"] += 1
        print(f"{latencies[-1]:6.1f} s  {text[:50]:50}  {'; '.join(shown) or repr(reply.text[:80])}", flush=True)
    await backend.aclose()
    ordered = sorted(latencies[1:]) or latencies
    print(dict(counts), f"first call {latencies[0]:.1f} s, median of the others {ordered[len(ordered) // 2]:.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path, help="the GGUF file")
    parser.add_argument("--tool-mode", choices=("native", "json_schema"), default="json_schema")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    with plain_loop(paper_start_config()) as loop, Agent(RulesBackend(), loop.server) as agent:
        system, tools = agent.history.messages[0], agent.tools
    backend = make_backend("llamacpp", model_path=args.model, tool_mode=args.tool_mode, threads=args.threads,
                           max_tokens=160, ctx_size=4096)
    asyncio.run(measure(backend, system, tools))


if __name__ == "__main__":
    main()
