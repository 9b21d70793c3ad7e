"""``agentic-mpc serve`` in a separate process, driven by a real MCP client over stdio and over HTTP."""

from __future__ import annotations

import asyncio
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcp import Client, StdioServerParameters

from agentic_mpc import cli

REPO = Path(__file__).resolve().parents[2]
# `agentic-mpc serve` once the CLI lists the command; the module's own entry point until then.
SERVE = ([sys.executable, "-m", "agentic_mpc", "serve"] if "serve" in cli.COMMANDS
         else [sys.executable, "-m", "agentic_mpc.commands.serve"])
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def run(coroutine, timeout_s: float = 90):
    return asyncio.run(asyncio.wait_for(coroutine, timeout_s))


async def read_json(client, uri):
    return json.loads((await client.read_resource(uri)).contents[0].text)


@pytest.mark.timing
def test_stdio_client_lists_reads_calls_and_is_refused_out_of_range():
    params = StdioServerParameters(command=SERVE[0], args=[*SERVE[1:], "--transport", "stdio", "--ambulance-at-s", "0"],
                                   cwd=str(REPO), env=ENV)

    async def go():
        async with Client(params, cache=None) as client:
            tools = sorted(t.name for t in (await client.list_tools()).tools)
            resources = sorted(str(r.uri) for r in (await client.list_resources()).resources)
            templates = [t.uri_template for t in (await client.list_resource_templates()).resource_templates]
            first = await read_json(client, "sumo://traffic")
            await asyncio.sleep(0.5)
            second = await read_json(client, "sumo://traffic")
            before = await read_json(client, "mpc://specification")
            refused = await client.call_tool("run_left_lane", {"v_ref": 1000})
            after_refusal = await read_json(client, "mpc://specification")
            accepted = await client.call_tool("run_left_lane", {"v_ref": 0})
            after = await read_json(client, "mpc://specification")
            await asyncio.sleep(2.0)
            ego = await read_json(client, "sumo://ego")
            return tools, resources, templates, first, second, before, refused, after_refusal, accepted, after, ego

    tools, resources, templates, first, second, before, refused, after_refusal, accepted, after, ego = run(go())
    assert tools == sorted([
        "clear_preferred_steering_direction", "run_center_lane", "run_left_lane", "run_right_lane",
        "set_preferred_steering_direction", "set_reference_speed", "change_lane", "keep_lane",
        "change_reference_speed", "set_following_distance", "change_following_distance", "clear_following_distance",
        "overtake",
    ])
    assert "sumo://traffic" in resources and "mpc://tactics" in resources and len(resources) == 10
    assert templates == ["sumo://vehicle/{vehicle_id}"]
    # the simulation advances in real time between the two reads
    assert second["time_s"] - first["time_s"] == pytest.approx(0.5, abs=0.3)
    car = {v["id"]: v for v in first["vehicles"]}["car0"]
    car_later = {v["id"]: v for v in second["vehicles"]}["car0"]
    assert car_later["x_m"] > car["x_m"]
    # out of range: an MCP tool error, nothing changes
    assert refused.is_error and "greater than the maximum" in refused.content[0].text
    assert after_refusal["version"] == before["version"] == 0
    assert after_refusal["attached"] == before["attached"]
    # a valid call changes the specification, and the car follows it
    assert not accepted.is_error
    assert after["version"] == 1 and after["summary"].startswith("path_tracking(lane=left, v_ref_mps=0)")
    assert ego["ego"]["y_m"] > 1.0 and ego["ego"]["speed_mps"] < 14.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_http_transport_serves_the_same_tools():
    port = _free_port()
    process = subprocess.Popen([*SERVE, "--transport", "http", "--port", str(port)], cwd=REPO, env=ENV,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            assert process.poll() is None, process.stderr.read()
            time.sleep(0.2)

        async def go():
            async with Client(f"http://127.0.0.1:{port}/mcp", cache=None) as client:
                tools = {t.name for t in (await client.list_tools()).tools}
                result = await client.call_tool("set_preferred_steering_direction", {"direction": "left"})
                spec = await read_json(client, "mpc://specification")
                return tools, result, spec

        tools, result, spec = run(go())
        assert "run_left_lane" in tools and not result.is_error
        assert spec["attached"][-1] == result.structured_content["attached"][-1]
        assert spec["attached"][-1]["direction"] == "left"
    finally:
        process.terminate()
        process.wait(10)
