"""Fourier MPPI: the model predictive controller (knows the vehicle and the primitives, nothing else).

Names are imported on first use, so that reading a configuration does not compile the kernels.
"""

from agentic_mpc.lazy_exports import lazy_exports

_EXPORTS = {
    "MPPIConfig": "agentic_mpc.controller.config",
    "ControlOutput": "agentic_mpc.controller.mppi",
    "FourierMPPI": "agentic_mpc.controller.mppi",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_exports("agentic_mpc.controller", _EXPORTS)
