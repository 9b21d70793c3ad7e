"""Lane geometry independent of any simulator: a centre line as arc-length tables (``polyline.py``) and its
compiled per-step evaluation (``kernels.py``: points, lane-following discs, side lines, projection)."""
