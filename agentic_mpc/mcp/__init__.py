"""The MCP side of agentic-mpc: the controller tools, the MCP server over them, and the contract they share
with MCP clients.

- :mod:`agentic_mpc.mcp.protocol`: what a client needs to talk to the server (resource URIs, the scheduling
  ``_meta`` key, argument validation), with no import of the server or the MCP SDK;
- :mod:`agentic_mpc.mcp.tools`: the controller tools, plain functions over a specification slot;
- :mod:`agentic_mpc.mcp.server`: the MCP server exposing the tools and the world's observations.

Nothing is imported here: import the module you need.
"""
