"""How a GGUF model's answers parse: ``python tests/agent/measure_model.py MODEL.gguf [--tool-mode native]``.

Not a test and not the accuracy suite (that is ``agentic-mpc eval-agent``'s job): each of 12 passenger
messages is answered once from ``[system, user]`` (the system message the agent builds at the paper's
Scenario 1 start: center lane at 15 m/s; on a left-hand road unless ``--righthand``) through the ``llamacpp``
backend, and every answer is counted as a valid call, a call with arguments outside the schema, an unparsed
call, or a reply; with the latency; and whether it is the RIGHT answer (:func:`expected`). ``--no-road``
drops the road section (``sumo://road``) from the system message, as an older server would. The numbers in
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
from agentic_mpc.agent.prompt import system_prompt
from agentic_mpc.mcp.protocol import validate_arguments
from agentic_mpc.world.plain_config import PlainRoad
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


def expected(edge: str) -> tuple[tuple[tuple[str, dict], ...], ...]:
    """The right answers to :data:`MESSAGES` (any one of the alternatives; ``()`` means no call), from the
    paper's start (center lane, 15 m/s, no steering preference) on a road whose edge lane is ``edge``."""
    steer = "set_preferred_steering_direction"
    speed = "set_reference_speed"
    return (
        ((steer, {"direction": "right"}),),
        ((steer, {"direction": "left"}),),
        ((f"run_{edge}_lane", {"v_ref": 0.0}),),
        (("run_center_lane", {"v_ref": 15.0}),),
        ((speed, {"v_ref": 10.0}), ("run_center_lane", {"v_ref": 10.0})),
        ((steer, {"direction": "right"}),),
        (),
        ((speed, {"v_ref": 20.0}), ("run_center_lane", {"v_ref": 20.0})),
        (("run_right_lane", {"v_ref": 15.0}),),
        (("clear_preferred_steering_direction", {}),),
        ((f"run_{edge}_lane", {"v_ref": 0.0}),),
        (("run_center_lane", {"v_ref": 0.0}), (speed, {"v_ref": 0.0})),
    )


def _matches(call, alternatives) -> bool:
    def same(a: dict, b: dict) -> bool:
        if set(a) != set(b):
            return False
        return all(abs(float(a[k]) - float(b[k])) <= 0.5 if isinstance(b[k], float) else a[k] == b[k] for k in b)

    try:
        return any(call.name == name and same(call.arguments, args) for name, args in alternatives)
    except (TypeError, ValueError):
        return False


def is_right(calls, alternatives) -> bool:
    """Right: no call where none is expected; else at least one call and every call one of the alternatives."""
    if not alternatives:
        return not calls
    return bool(calls) and all(call.error is None and _matches(call, alternatives) for call in calls)


async def measure(backend, system: Message, tools, edge: str = "left") -> None:
    by_name = {t.name: t for t in tools}
    counts: Counter[str] = Counter()
    latencies = []
    right = 0
    for text, alternatives in zip(MESSAGES, expected(edge), strict=True):
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
        ok = is_right(reply.tool_calls, alternatives)
        right += ok
        print(f"{latencies[-1]:6.1f} s  {'RIGHT' if ok else 'wrong'}  {text[:50]:50}  "
              f"{'; '.join(shown) or repr(reply.text[:80])}", flush=True)
    await backend.aclose()
    ordered = sorted(latencies[1:]) or latencies
    print(f"right {right}/{len(MESSAGES)}", dict(counts), f"first call {latencies[0]:.1f} s, median of the others {ordered[len(ordered) // 2]:.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path, help="the GGUF file")
    parser.add_argument("--tool-mode", choices=("native", "json_schema"), default="json_schema")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--righthand", action="store_true", help="a right-hand road (default: left-hand)")
    parser.add_argument("--no-road", action="store_true", help="no road section in the system message")
    parser.add_argument("--show-prompt", action="store_true", help="print the system message first")
    args = parser.parse_args()
    config = paper_start_config().model_copy(update={"road": PlainRoad(lefthand=not args.righthand)})
    with plain_loop(config) as loop, Agent(RulesBackend(), loop.server) as agent:
        system, tools = agent.history.messages[0], agent.tools
    if args.no_road:
        initial = system.data["initial_specification"]
        system = Message("system", system_prompt(initial, tools), data=system.data, tau=0)
    if args.show_prompt:
        print(system.content, "\n", flush=True)
    backend = make_backend("llamacpp", model=args.model, tool_mode=args.tool_mode, threads=args.threads,
                           max_tokens=160, ctx_size=4096)
    asyncio.run(measure(backend, system, tools, "right" if args.righthand else "left"))


if __name__ == "__main__":
    main()
