"""The run: one loop that steps any world with the controller, the specification, the tools, the MCP server,
the agent and the message timeline (:mod:`~agentic_mpc.run.loop`), and what it records
(:mod:`~agentic_mpc.run.recorder`)."""
