"""The worlds the car drives in: the one :class:`~agentic_mpc.world.base.World` protocol, the observation every
world produces, the plain-Python world, collisions and emergency vehicles (SUMO's world is in ``sumo/``)."""

ALERT_DISTANCE_M = 80.0
"""How far behind the ego an emergency vehicle starts to matter, unless a scenario says otherwise (here, not in
``emergency.py``, so that the agent's settings can name it without loading the observation types)."""
