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
(streamable HTTP at ``http://HOST:PORT/mcp``; see docs/serving.md). Over HTTP a request whose Host or Origin
is not the server's own (or one given with ``--allow-host`` / ``--allow-origin``) is refused; a bearer token
(``AGENTIC_MPC_TOKEN``, ``--token-file`` or ``--generate-token``, never on the command line) is required
when one is configured, and always for a bind that is not loopback; tool calls are rate limited per client
(``--rate-limit``).

``--view`` (HTTP only) adds a live page at ``http://HOST:PORT/``: the replay's bird's-eye view as the run goes,
the specification, messages and tool calls, and a chat box whose messages go to the run's own agent (the
scenario's backend, in realtime mode: the car never waits for it) while MCP hosts can still connect at
``/mcp``. With a token, open ``http://HOST:PORT/?token=...`` once (it becomes a cookie). See
:mod:`agentic_mpc.replay.live_app`. See :mod:`agentic_mpc.mcp.server` for the tools, resources
and host configuration, e.g. Claude Desktop::

    {"mcpServers": {"agentic-mpc": {"command": "agentic-mpc", "args": ["serve", "--transport", "stdio"]}}}

and the MCP Inspector's command line::

    npx @modelcontextprotocol/inspector --cli agentic-mpc serve --method tools/list
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from pathlib import Path

from agentic_mpc.commands import CommandInputError, agent_setting, scenario_file, scenario_for
from agentic_mpc.shipped import scenarios_dir

DEFAULT_SCENARIO = scenarios_dir() / "plain_world_traffic.yaml"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "serve", help="run the simulation and expose it as an MCP server", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_arguments(parser)
    parser.set_defaults(handler=run)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", nargs="?", type=scenario_file, default=None, metavar="SCENARIO",
                        help="scenario YAML or a shipped scenario's name (default: plain_world_traffic, no SUMO)")
    parser.add_argument("--variant", default=None, help="with SCENARIO: the variant (default: the base scenario)")
    parser.add_argument("--out", type=Path, default=None, help="with SCENARIO: where the run's files go")
    parser.add_argument("--agent", type=agent_setting, action="append", default=[], metavar="KEY=VALUE",
                        help="override a setting of the scenario's agent (repeatable), e.g. --agent backend=llamacpp "
                             "--agent model=PATH.gguf --agent temperature=0.2 (see docs/llm-backends.md)")
    parser.add_argument("--transport", choices=("stdio", "http"), default=None,
                        help="stdio (default) or http (the default with --view)")
    parser.add_argument("--view", action="store_true",
                        help="http: a live page at / with the bird's-eye view and a chat box to the run's agent")
    parser.add_argument("--host", default="127.0.0.1", help="http: interface to listen on")
    parser.add_argument("--port", type=int, default=8765, help="http: port (the endpoint is /mcp)")
    parser.add_argument("--allow-host", action="append", default=[], metavar="HOST[:PORT]",
                        help="http: also accept this Host header (repeatable; e.g. mybox.lan:8765)")
    parser.add_argument("--allow-origin", action="append", default=[], metavar="ORIGIN",
                        help="http: also accept this Origin header (repeatable; e.g. http://mybox.lan:8765)")
    parser.add_argument("--token-file", type=Path, default=None,
                        help="http: file holding the bearer token clients must send (else $AGENTIC_MPC_TOKEN)")
    parser.add_argument("--generate-token", action="store_true",
                        help="http: generate a bearer token and print it once to stderr")
    parser.add_argument("--rate-limit", type=float, default=20.0, metavar="N",
                        help="http: tool calls per second per client (bursts of 2N; default 20)")
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
    if args.transport is None:
        args.transport = "http" if args.view else "stdio"
    if args.view and args.transport != "http":
        print("error: --view needs --transport http (the page is served next to the MCP endpoint)", file=sys.stderr)
        return 2
    if args.time_scale <= 0:
        print("error: --time-scale must be positive", file=sys.stderr)
        return 2
    listening = None
    if args.transport == "http":  # every refusal before the simulation starts and before listening
        from agentic_mpc.mcp.http import BindError, bind_socket, check_bind

        try:
            args.token = _token(args)
            if not (args.rate_limit > 0 and args.rate_limit != float("inf")):
                raise BindError("--rate-limit must be a positive number")
            check_bind(args.host, args.token)
            listening = bind_socket(args.host, args.port)
        except BindError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
    elif args.token_file is not None or args.generate_token:
        print("error: --token-file and --generate-token apply to --transport http", file=sys.stderr)
        return 2
    try:
        return serve_scenario(args, listening)
    finally:
        if listening is not None:
            listening.close()


def _token(args: argparse.Namespace) -> str | None:
    """The bearer token: from --token-file, $AGENTIC_MPC_TOKEN or generated (printed once); None without."""
    import secrets

    from agentic_mpc.mcp.http import TOKEN_ENV, BindError

    from_env = os.environ.get(TOKEN_ENV, "").strip() or None
    if sum(x is not None and x is not False for x in (args.token_file, from_env, args.generate_token or None)) > 1:
        raise BindError(f"give the token one way: --token-file, ${TOKEN_ENV} or --generate-token")
    if args.token_file is not None:
        try:
            token = args.token_file.read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError) as error:
            raise BindError(f"cannot read the token file {args.token_file}: {error}") from None
        if not token:
            raise BindError(f"the token file {args.token_file} is empty")
        if os.name == "posix" and args.token_file.stat().st_mode & 0o077:
            print(f"warning: {args.token_file} is readable by other users (chmod 600 it)", file=sys.stderr)
        return token
    if args.generate_token:
        token = secrets.token_urlsafe(32)
        print(f"bearer token (shown once; clients send 'Authorization: Bearer <token>'): {token}",
              file=sys.stderr, flush=True)
        return token
    return from_env


def _serve(server: object, args: argparse.Namespace, listening: object = None, routes: list | None = None) -> None:
    if args.transport == "stdio":
        server.mcp_server.run("stdio")  # type: ignore[attr-defined]
        return
    from agentic_mpc.mcp.http import RateLimiter, is_loopback, serve_http

    limiter = RateLimiter(rate=args.rate_limit, burst=max(1.0, 2 * args.rate_limit))
    server.mcp_server.tool_call_gate = limiter.gate  # type: ignore[attr-defined]
    if not is_loopback(args.host) and not args.allow_host:
        print(f"note: only requests with Host {args.host}:{args.port} are accepted; name the address clients use "
              "with --allow-host NAME:PORT", file=sys.stderr)
    signal.signal(signal.SIGTERM, _interrupt)  # uvicorn re-raises SIGTERM after its shutdown: end like SIGINT
    auth = "bearer token required" if args.token else "no token (loopback only)"
    print(f"MCP server at http://{args.host}:{args.port}/mcp ({auth}; at most {args.rate_limit:g} tool calls/s "
          "per client)", file=sys.stderr, flush=True)
    if routes:
        login = "?token=<token>" if args.token else ""
        print(f"live view at http://{args.host}:{args.port}/{login}", file=sys.stderr, flush=True)
    serve_http(server.mcp_server, listening, args.host, args.port, token=args.token,  # type: ignore[attr-defined]
               allow_hosts=args.allow_host, allow_origins=args.allow_origin, extra_routes=routes or ())


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def serve_scenario(args: argparse.Namespace, listening: object = None) -> int:
    """A scenario in real time behind the MCP server; the host is the agent."""
    from agentic_mpc.scenario.runner import ScenarioRun

    try:
        scenario = scenario_for("serve", args.scenario or DEFAULT_SCENARIO, args.variant, args.seed or None, args.agent)
    except CommandInputError as error:
        print(error, file=sys.stderr)
        return 2
    if args.scenario is None:
        scenario = _with_ambulance_at(scenario, args.ambulance_at_s)
    if args.duration_s is not None:
        scenario = scenario.model_copy(update={"duration_s": args.duration_s})
    if args.view:  # the page's chat reaches the run's own agent, which must never hold up the car
        scenario = scenario.model_copy(update={"agent": scenario.agent.model_copy(update={"mode": "realtime"})})
    out = args.out or Path("out") / "serve" / scenario.name / scenario.variant / f"seed-{scenario.seed}"
    run = ScenarioRun(scenario, out, embedded_agent=args.view, pace=args.time_scale,
                      server_options={"publish_interval_s": args.publish_interval_s})
    simulation = threading.Thread(target=_run_quietly, args=(run,), name="simulation", daemon=True)
    simulation.start()  # libsumo stays on this one thread; MCP reads only the immutable observation
    run.ready.wait()
    if run.server is None:
        print(f"error: the scenario could not start: {run.error}", file=sys.stderr)
        return 1
    logging.getLogger(__name__).info("%s running in SUMO; MCP over %s; files to %s", scenario.name, args.transport, out)
    routes = _live_view(run, scenario, simulation, args) if args.view else None
    try:
        _serve(run.server, args, listening, routes)
    except KeyboardInterrupt:
        pass
    finally:
        run.stop.set()
        simulation.join(timeout=30)
    return 0


def _live_view(run: object, scenario: object, simulation: threading.Thread, args: argparse.Namespace) -> list:
    """The live page's routes over ``run`` (see :mod:`agentic_mpc.replay.live_app`)."""
    import json

    from agentic_mpc.mcp.http import RateLimiter, security_settings
    from agentic_mpc.replay.live import LiveScene
    from agentic_mpc.replay.live_app import LiveView

    loop = run.loop  # type: ignore[attr-defined]

    def deliver(text: str) -> float:
        t = round(loop.world.time_s, 3)
        report = loop.agent.deliver(text, sim_time_s=t)
        if report.done() and report.result().ended == "rejected":
            raise ValueError("; ".join(report.result().errors))
        return t

    def finished() -> str | None:
        if simulation.is_alive():
            return None
        error = run.error  # type: ignore[attr-defined]
        return f"failed: {error}" if error is not None else f"ended at {loop.world.time_s:.2f} s"

    scene = LiveScene(loop, json.loads(scenario.model_dump_json()))  # type: ignore[attr-defined]
    view = LiveView(scene, deliver, finished, security_settings(args.host, args.port, args.allow_host,
                                                                 args.allow_origin), RateLimiter(rate=2.0, burst=5.0))
    return view.routes()


def _with_ambulance_at(scenario: object, at_s: float) -> object:
    """The default scenario with its ambulance appearing at ``at_s`` (negative: without it)."""
    world = scenario.plain_world  # type: ignore[attr-defined]
    vehicles = tuple(
        v.model_copy(update={"appear_at_s": at_s}) if v.emergency else v
        for v in world.vehicles if not (v.emergency and at_s < 0)
    )
    return scenario.model_copy(update={"world": world.model_copy(update={"vehicles": vehicles})})  # type: ignore[attr-defined]


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
