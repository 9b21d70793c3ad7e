"""Subcommands of the ``agentic-mpc`` CLI, one module each (see ``agentic_mpc/cli.py``)."""
