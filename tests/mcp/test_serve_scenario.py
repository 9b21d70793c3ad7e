"""``agentic-mpc serve SCENARIO``: a SUMO scenario behind the MCP server, driven by a client in another process."""

from __future__ import annotations

import asyncio
import json
import os
import sys
from pathlib import Path

import pandas as pd
from mcp import Client, StdioServerParameters

REPO = Path(__file__).resolve().parents[2]


async def read_json(client, uri):
    return json.loads((await client.read_resource(uri)).contents[0].text)


def test_an_mcp_host_drives_the_sumo_scenario(tmp_path):
    out = tmp_path / "run"
    params = StdioServerParameters(
        command=sys.executable,
        args=["-m", "agentic_mpc", "serve", str(REPO / "scenarios/paper_emergency_response.yaml"),
              "--variant", "no_message", "--time-scale", "0.25", "--duration-s", "6", "--out", str(out)],
        cwd=str(REPO), env={**os.environ, "OMP_NUM_THREADS": "1"},
    )

    async def go():
        async with Client(params, cache=None) as client:
            tools = {t.name for t in (await client.list_tools()).tools}
            first = await read_json(client, "sumo://traffic")
            emergency = await read_json(client, "sumo://emergency-vehicles")
            await asyncio.sleep(0.5)
            second = await read_json(client, "sumo://traffic")
            refused = await client.call_tool("run_left_lane", {"v_ref": -1})
            unchanged = await read_json(client, "mpc://specification")
            accepted = await client.call_tool("run_left_lane", {"v_ref": 0})
            changed = await read_json(client, "mpc://specification")
            ambulance = await read_json(client, "sumo://vehicle/ambulance")
            await asyncio.sleep(1.0)
            return tools, first, emergency, second, refused, unchanged, accepted, changed, ambulance

    tools, first, emergency, second, refused, unchanged, accepted, changed, ambulance = asyncio.run(
        asyncio.wait_for(go(), 120)
    )
    assert {"run_center_lane", "run_left_lane", "set_preferred_steering_direction"} <= tools
    assert second["time_s"] > first["time_s"]  # SUMO advances between reads (4x real time here)
    ids = json.dumps(first)
    assert "block_left" in ids and "ambulance" in json.dumps(emergency)
    assert refused.is_error and unchanged["version"] == 0
    assert not accepted.is_error and changed["version"] == 1 and "lane=left, v_ref_mps=0" in changed["summary"]
    assert "ambulance" in json.dumps(ambulance)
    # the server wrote the run's files when it stopped; the host's change is in the events
    summary = pd.read_csv(out / "summary.csv").iloc[0]
    assert summary["status"] == "ok" and summary["agent_tool_calls"] == 0
    events = pd.read_csv(out / "events.csv")
    assert (events["event"] == "specification").sum() == 1
    trajectory = pd.read_csv(out / "trajectory.csv")
    assert (trajectory["tracked_lane"] == "left").any()
