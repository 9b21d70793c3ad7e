"""Imported once by the batch's fork server: every run forked from it starts with the heavy imports
(mcp, libsumo, pandas, matplotlib, numba) done and the controller kernel loaded, instead of paying about
1.7 s for them per run. Nothing here starts a simulation: libsumo allows one per process, and each forked
run starts its own."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot  # noqa: E402, F401
import numpy as np  # noqa: E402
import pandas  # noqa: E402, F401

# The layers import lazily (a single command pays only for what it uses); a fork server wants them all.
from agentic_mpc.plots import demo_figures, figures  # noqa: E402, F401
from agentic_mpc.agent import agent  # noqa: E402, F401
from agentic_mpc.agent.backends import openai, rules  # noqa: E402, F401
from agentic_mpc.controller.config import MPPIConfig  # noqa: E402
from agentic_mpc.controller.mppi import FourierMPPI  # noqa: E402
from agentic_mpc.primitives import Specification  # noqa: E402
from agentic_mpc.run import loop  # noqa: E402, F401
from agentic_mpc.scenario import runner, specification  # noqa: E402, F401
from agentic_mpc.sumo import world  # noqa: E402, F401
from agentic_mpc.world import plain  # noqa: E402, F401

# One tiny step loads the fused kernel from numba's cache (same signature as any horizon or sample count).
FourierMPPI(MPPIConfig(horizon=4, samples=4)).step(np.array([0.0, 0.0, 0.0, 1.0]), Specification.of())
