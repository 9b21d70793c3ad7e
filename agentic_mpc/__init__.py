"""agentic-mpc: a language-model agent rewrites the specification of a Fourier MPPI controller while the
car drives, in an Eclipse SUMO co-simulation (Miyaoka & Inoue, "Agentic MPC for Semantic Control System
Resynthesis")."""

__version__ = "0.1.0"
