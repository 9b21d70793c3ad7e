"""A run process started as a fresh interpreter: ``python -m agentic_mpc.batch ARGS`` (see ``worker.py``)."""

import sys

from agentic_mpc.batch.worker import worker_main

if __name__ == "__main__":
    sys.exit(worker_main(sys.argv[1:]))
