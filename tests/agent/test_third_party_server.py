"""A third-party MCP server as a knowledge source: the reference filesystem server from the npm registry
(``@modelcontextprotocol/server-filesystem``, installed into ``.cache/npm/`` by ``make test``) serving a
user's manual folder; the agent lists its tools beside the controller's and answers from a file it read."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from agentic_mpc.agent import Agent, AgentConfig
from agentic_mpc.agent.backends.openai import OpenAIBackend
from agentic_mpc.agent.settings import McpServerSettings, OpenAISettings
from tests.agent.scripted_llm import ScriptedLLM, calls, text, tool_call

SERVER = Path(__file__).resolve().parents[2] / ".cache/npm/node_modules/@modelcontextprotocol/server-filesystem/dist/index.js"
pytestmark = pytest.mark.skipif(
    not SERVER.is_file() or shutil.which("node") is None,
    reason=f"the npm filesystem server is not installed at {SERVER} (make test installs it where npm is) or no node")


def test_the_agent_searches_a_users_manual_folder_through_the_filesystem_server(loop, server, tmp_path):
    manuals = tmp_path / "manuals"
    manuals.mkdir()
    (manuals / "trailer.md").write_text("# Trailer manual\n\nThe trailer hitch takes 150 kg of vertical load.\n")
    files = McpServerSettings(name="files", command=("node", str(SERVER), str(manuals)))
    script = [
        calls(tool_call("files__search_files", {"path": str(manuals), "pattern": "**/*trailer*"}, "c1")),
        calls(tool_call("files__read_text_file", {"path": str(manuals / "trailer.md")}, "c2")),
        text("The hitch takes 150 kg (trailer.md)."),
    ]
    before = loop.slot.current
    with ScriptedLLM(script) as llm, Agent(OpenAIBackend(OpenAISettings(base_url=llm.base_url, model="t",
                                                                        api_key_env=None)), server,
                                          AgentConfig(mcp_servers=(files,))) as agent:
        names = {t.name for t in agent.tools}
        report = agent.deliver("How much load does the trailer hitch take?").result(60)
        third = llm.requests[2]
    assert {"files__read_text_file", "files__search_files", "run_left_lane"} <= names
    assert report.ended == "idle" and not report.errors
    results = [m["content"] for m in third["messages"] if m["role"] == "tool"]
    assert "trailer.md" in results[0] and "150 kg" in results[1]
    assert loop.slot.current is before  # a filesystem read changes no specification
