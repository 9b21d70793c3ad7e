"""``agentic-mpc serve [SCENARIO]``: drive the car and expose its controller tools and observations as an MCP server.

The scenario's run loop (its world: SUMO or plain Python) runs in real time (``--time-scale`` stretches it)
in a background thread while the MCP server answers: the MCP host is the agent (the scenario's own message
timeline and agent are not used) and its tool calls apply when they arrive. The run's files are written to
``--out`` when the simulation ends or the server stops.

Without a SCENARIO, ``scenarios/plain_world_traffic.yaml`` runs (no SUMO): a straight 3-lane road, lanes
3.5 m apart, speed limit 25 m/s, the paper's initial specification (center lane at 15 m/s plus obstacle
avoidance) with an obstacle 80 m ahead, a slower car in the right lane and an ambulance that comes up behind
the ego at ``--ambulance-at-s``.

Transports: ``--transport stdio`` (the default: for Claude Desktop, MCP Inspector and other hosts that
start the server themselves; nothing but MCP goes to stdout, logs go to stderr) and ``--transport http``
(streamable HTTP at ``http://HOST:PORT/mcp``). See :mod:`agentic_mpc.mcp.server` for the tools, resources
and host configuration, e.g. Claude Desktop::

    {"mcpServers": {"agentic-mpc": {"command": "agentic-mpc", "args": ["serve", "--transport", "stdio"]}}}

and the MCP Inspector's command line::

    npx @modelcontextprotocol/inspector --cli agentic-mpc serve --method tools/list
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import threading
from pathlib import Path

DEFAULT_SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "plain_world_traffic.yaml"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "serve", help="run the simulation and expose it as an MCP server", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_arguments(parser)
    parser.set_defaults(handler=run)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", nargs="?", type=Path, default=None, metavar="SCENARIO",
                        help="scenario YAML to run (default: scenarios/plain_world_traffic.yaml, no SUMO)")
    parser.add_argument("--variant", default=None, help="with SCENARIO: the variant (default: the base scenario)")
    parser.add_argument("--out", type=Path, default=None, help="with SCENARIO: where the run's files go")
    parser.add_argument("--transport", choices=("stdio", "http"), default="stdio")
    parser.add_argument("--host", default="127.0.0.1", help="http: interface to listen on")
    parser.add_argument("--port", type=int, default=8765, help="http: port (the endpoint is /mcp)")
    parser.add_argument("--time-scale", type=float, default=1.0,
                        help="wall seconds per simulated second (1 = real time, 2 = half speed)")
    parser.add_argument("--duration-s", type=float, default=None, help="stop the simulation after this sim time")
    parser.add_argument("--ambulance-at-s", type=float, default=30.0,
                        help="without SCENARIO: sim time the ambulance appears behind the ego (negative: none)")
    parser.add_argument("--seed", type=int, default=0, help="the run's seed (default: the scenario's)")
    parser.add_argument("--publish-interval-s", type=float, default=0.2,
                        help="sim seconds between resource-updated notifications for ego and traffic")
    parser.add_argument("--log-level", default="WARNING", choices=("DEBUG", "INFO", "WARNING", "ERROR"))


def run(args: argparse.Namespace) -> int:
    # stdout belongs to the MCP protocol on stdio: everything else goes to stderr.
    logging.basicConfig(level=args.log_level, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s")
    if args.time_scale <= 0:
        print("error: --time-scale must be positive", file=sys.stderr)
        return 2
    return serve_scenario(args)


def _serve(server: object, args: argparse.Namespace) -> None:
    if args.transport == "stdio":
        server.mcp_server.run("stdio")  # type: ignore[attr-defined]
    else:
        print(f"MCP server at http://{args.host}:{args.port}/mcp", file=sys.stderr, flush=True)
        server.mcp_server.run("streamable-http", host=args.host, port=args.port)  # type: ignore[attr-defined]


def serve_scenario(args: argparse.Namespace) -> int:
    """A scenario in real time behind the MCP server; the host is the agent."""
    from agentic_mpc.scenario.runner import ScenarioRun
    from agentic_mpc.scenario.schema import load_scenario
    from agentic_mpc.scenario.yaml_source import ScenarioFileError

    try:
        scenario = load_scenario(args.scenario or DEFAULT_SCENARIO).variant(args.variant)
    except ScenarioFileError as error:
        print(error, file=sys.stderr)
        return 2
    if args.scenario is None:
        scenario = _with_ambulance_at(scenario, args.ambulance_at_s)
    if args.seed:
        scenario = scenario.with_seed(args.seed)
    if args.duration_s is not None:
        scenario = scenario.model_copy(update={"duration_s": args.duration_s})
    out = args.out or Path("out") / "serve" / scenario.name / scenario.variant / f"seed-{scenario.seed}"
    run = ScenarioRun(scenario, out, embedded_agent=False, pace=args.time_scale,
                      server_options={"publish_interval_s": args.publish_interval_s})
    simulation = threading.Thread(target=_run_quietly, args=(run,), name="simulation", daemon=True)
    simulation.start()  # libsumo stays on this one thread; MCP reads only the immutable observation
    run.ready.wait()
    if run.server is None:
        print(f"error: the scenario could not start: {run.error}", file=sys.stderr)
        return 1
    logging.getLogger(__name__).info("%s running in SUMO; MCP over %s; files to %s", scenario.name, args.transport, out)
    try:
        _serve(run.server, args)
    except KeyboardInterrupt:
        pass
    finally:
        run.stop.set()
        simulation.join(timeout=30)
    return 0


def _with_ambulance_at(scenario: object, at_s: float) -> object:
    """The default scenario with its ambulance appearing at ``at_s`` (negative: without it)."""
    world = scenario.plain_world  # type: ignore[attr-defined]
    vehicles = tuple(
        v.model_copy(update={"appear_at_s": at_s}) if v.emergency else v
        for v in world.vehicles if not (v.emergency and at_s < 0)
    )
    return scenario.model_copy(update={"plain_world": world.model_copy(update={"vehicles": vehicles})})  # type: ignore[attr-defined]


def _run_quietly(run: object) -> None:
    try:
        run.run()  # type: ignore[attr-defined]
    except Exception:  # recorded in run.error and the run's summary.csv; the server keeps answering
        logging.getLogger(__name__).exception("the simulation failed")


if __name__ == "__main__":  # python -m agentic_mpc.commands.serve (before the CLI lists the command)
    for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, "1")
    main_parser = argparse.ArgumentParser(prog="agentic-mpc serve", description=__doc__)
    add_arguments(main_parser)
    sys.exit(run(main_parser.parse_args()))
