"""SUMO networks and route files of the scenarios; `python -m sumo_nets.build` regenerates the nets."""
