"""The files of a run directory and their columns, named once: the recorder writes them, the reader
(:mod:`agentic_mpc.run.reader`) and everyone after it read them.

Nothing here loads anything: the batch's parent process and light commands import it too.
"""

TRAJECTORY = "trajectory.csv"
"""One row per control step: the plant's state, the world's view of the ego, the controller's output."""
TRAFFIC = "traffic.csv"
"""The other road users every few steps."""
PLAN = "plan.csv"
"""The controller's optimal predicted trajectory every few steps (when the replay asks for it)."""
EVENTS = "events.csv"
"""Messages, tool calls, specification changes, collisions."""
OBSTACLES = "obstacles.csv"
"""J2's discs of each static obstacle."""
OBSTACLE_PASSES = "obstacle_passes.csv"
"""One row per static obstacle: side, clearance, when passed."""
SIGNALS = "signals.csv"
"""The traffic lights the ego's route meets: a row each time one changes (only runs that met a light have it)."""
SUMMARY = "summary.csv"
"""One row: the run's identity and its metrics (in a batch, the batch's record of the run)."""
SCENARIO = "scenario.json"
"""The scenario as run (variant and seed applied): the road, the route files, the vehicles."""
TRANSCRIPT = "transcript.jsonl"
FIGURE = "trajectory.png"
REPLAY = "replay.html"

TRAFFIC_COLUMNS = ("time_s", "id", "type_id", "vclass", "x_m", "y_m", "heading_rad", "speed_mps", "lane_id",
                   "road_s_m", "gap_m", "relation", "emergency")
EVENT_COLUMNS = ("event", "tau", "sim_time_s", "role", "source", "content", "tool", "arguments", "ok", "result",
                 "error", "apply_at_s", "client")
"""``client`` (last) is set on ``tool_call_received`` rows: one per tool call the MCP server received, with who
made it (``name/version; session=ID; address=IP``). ``tool_call`` rows are the embedded agent's own transcript."""
PLAN_COLUMNS = ("time_s", "k", "x_m", "y_m")
"""``k`` = 1..H along the horizon; a plan may add ``ref_x_m, ref_y_m`` (J1's reference points)."""
OBSTACLE_COLUMNS = ("id", "x_m", "y_m", "radius_m")
SIGNAL_COLUMNS = ("time_s", "junction_id", "state", "stop_s_m", "x_m", "y_m", "heading_rad")
"""``state``: green, yellow, red, off, or unobserved (the junction is no longer ahead); ``x_m, y_m, heading_rad``:
the stop line of the ego's movement on its lane (:mod:`agentic_mpc.run.signal_log`)."""
OBSTACLE_PASS_COLUMNS = ("id", "lane_index", "road_s_m", "side", "min_clearance_m", "passed_at_s")
EGO_COLUMNS = ("time_s", "x_m", "y_m", "phi_rad", "v_mps")
"""The columns of ``trajectory.csv`` every reader needs (the recorder writes many more)."""
TIMING_COLUMNS = ("solve_ms", "step_ms", "controller_ms_median", "controller_ms_p99", "wall_s")
"""Wall-clock columns (trajectory and summary): the only ones a seed cannot fix (every other is reproducible)."""

REQUIRED = {
    TRAJECTORY: EGO_COLUMNS,
    TRAFFIC: ("time_s", "id", "x_m", "y_m"),
    EVENTS: ("event", "sim_time_s"),
    OBSTACLES: OBSTACLE_COLUMNS,
    PLAN: PLAN_COLUMNS,
    SIGNALS: SIGNAL_COLUMNS,
}
"""The columns without which a file is not the run's: the reader refuses it."""
