"""Fourier MPPI: the model predictive controller (knows the vehicle and the primitives, nothing else).

Names are imported on first use, so that reading a configuration does not compile the kernels.
"""

from importlib import import_module
from typing import Any

_EXPORTS = {
    "MPPIConfig": "agentic_mpc.controller.config",
    "ControlOutput": "agentic_mpc.controller.mppi",
    "FourierMPPI": "agentic_mpc.controller.mppi",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'agentic_mpc.controller' has no attribute {name!r}")
    return getattr(import_module(_EXPORTS[name]), name)
