import sys

from agentic_mpc.cli import main

sys.exit(main())
