"""Driving tactics, independent of any simulator: rules that read the observation and shape what the controller
is asked to do (the lane J1 follows, the lanes open for passing, J0's room behind a queue, which followers let the
ego in). ``config.py`` is the scenario's section (light: pydantic only), ``layer.py`` the layer the run loop asks,
``detour.py`` the rules that choose J1's lane, ``queues.py`` the blockages, ``covers.py`` the discs round a car.
See docs/traffic.md."""
