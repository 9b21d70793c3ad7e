"""Fourier MPPI: the model predictive controller (knows the vehicle and the primitives, nothing else)."""

from agentic_mpc.controller.config import MPPIConfig
from agentic_mpc.controller.mppi import ControlOutput, FourierMPPI

__all__ = ["ControlOutput", "FourierMPPI", "MPPIConfig"]
