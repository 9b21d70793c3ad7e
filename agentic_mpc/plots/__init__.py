"""Figures people would rather look at than read, and the drawing the replay's animation shares.

- :mod:`~agentic_mpc.plots.figures`: one run's ``trajectory.png`` (:func:`run_figure`) and a batch's figures
  per scenario (:func:`batch_figures`), from their directories;
- :mod:`~agentic_mpc.plots.demo_figures`: the obstacle demo's (:func:`birds_eye`, :func:`time_series`);
- :mod:`~agentic_mpc.plots.panels`: the bird's-eye overview and zoomed panels, at the places of
  :mod:`~agentic_mpc.plots.places` (where things happen; no matplotlib);
- :mod:`~agentic_mpc.plots.drawing`: the palette, roads, footprints, obstacles;
- :mod:`~agentic_mpc.plots.runs`: a run as the figures see it, read through :mod:`agentic_mpc.run.reader`;
- :mod:`~agentic_mpc.plots.road`: the road a run drove on, rebuilt from its ``scenario.json`` (no matplotlib).

Roads come from a lanes source: any object whose ``lanes()`` returns a
:class:`~agentic_mpc.world.lanes.RoadLanes` (every world, or :class:`~agentic_mpc.plots.road.RunRoad`).
The names below load their module (and matplotlib) when first used: importing the package, or its
:mod:`~agentic_mpc.plots.road` alone (as the replay page does), loads no matplotlib.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "run_figure": "figures", "batch_figures": "figures", "birds_eye": "demo_figures", "time_series": "demo_figures",
    "colour_of": "drawing", "PALETTE": "drawing", "VARIANT_COLOURS": "drawing",
}

__all__ = ["PALETTE", "VARIANT_COLOURS", "batch_figures", "birds_eye", "colour_of", "run_figure", "time_series"]


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
