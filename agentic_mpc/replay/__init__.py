"""The animated replay of a run: :func:`write_replay` turns a run directory into one self-contained HTML page."""

from agentic_mpc.replay.data import ReplayInputError, load_run
from agentic_mpc.replay.html import render_page, write_replay

__all__ = ["ReplayInputError", "load_run", "render_page", "write_replay"]
