"""Imported once by the batch's fork server: every run forked from it starts with the heavy imports
(mcp, libsumo, pandas, matplotlib, numba) done and the controller kernel loaded, instead of paying about
1.7 s for them per run. Nothing here starts a simulation: libsumo allows one per process, and each forked
run starts its own."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot  # noqa: E402, F401
import numpy as np  # noqa: E402

from agentic_mpc import plots  # noqa: E402, F401
from agentic_mpc.controller import FourierMPPI, MPPIConfig  # noqa: E402
from agentic_mpc.primitives import Specification  # noqa: E402
from agentic_mpc.scenario import runner  # noqa: E402, F401

# One tiny step loads the fused kernel from numba's cache (same signature as any horizon or sample count).
FourierMPPI(MPPIConfig(horizon=4, samples=4)).step(np.array([0.0, 0.0, 0.0, 1.0]), Specification.of())
