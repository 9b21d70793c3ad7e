"""The SUMO world: SUMO drives the traffic, our controller and bicycle model drive the ego.

- :mod:`~agentic_mpc.sumo.bridge`: the only package that imports libsumo (conventions converted there);
- :mod:`~agentic_mpc.sumo.network`: lane geometry of a net as the controller's ``LanePath`` s;
- :mod:`~agentic_mpc.sumo.config`: what a SUMO world is made of (validated, imports nothing heavy);
- :mod:`~agentic_mpc.sumo.observations`: the bridge's records -> the world's ``Observation``;
- :mod:`~agentic_mpc.sumo.surroundings`: observation -> the controller's ``Surroundings``;
- :mod:`~agentic_mpc.sumo.world`: :class:`~agentic_mpc.sumo.world.SumoWorld`, the world interface over SUMO;
- :mod:`~agentic_mpc.sumo.scenarios`: ready-made configs for the paper's scenarios and the traffic runs.

libsumo runs one simulation per process: run batches in several processes. Nothing is imported here, so
that importing a submodule (the config, say) does not load libsumo.
"""
