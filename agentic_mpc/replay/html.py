"""One self-contained HTML page that plays a run: the scene of :mod:`agentic_mpc.replay.data` with the page's
script and style inlined (no server, no network, no external fonts).

The page exposes ``window.replayState`` (time, ego pose, ids of the drawn vehicles, visible captions, the
attached specification, the traffic lights shown: ``signals``) and ``window.replaySeek(t)`` for tests and
scripting.
"""

from __future__ import annotations

import html
import json
from importlib import resources
from pathlib import Path
from typing import Any

from agentic_mpc.replay.data import load_run
from agentic_mpc.run.files import REPLAY

PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>Replay: {title}</title>
<style>
{css}
</style>
</head>
<body>
<header>
  <h1 id="title">{title}</h1>
  <span class="muted" id="description"></span>
  <span class="muted" id="summary"></span>
</header>
<main>
  <section id="stage">
    <div id="canvas-box">
      <canvas id="view" aria-label="bird's-eye view following the ego"></canvas>
      <div id="zoom"><button id="zoom-out" title="zoom out">−</button><button id="zoom-in" title="zoom in">+</button></div>
      <div id="captions" aria-live="polite"></div>
    </div>
    <div id="controls">
      <button id="play">▶ Play</button>
      <label>speed <select id="speed">
        <option value="0.25">0.25×</option><option value="0.5">0.5×</option><option value="1" selected>1×</option>
        <option value="2">2×</option><option value="4">4×</option><option value="8">8×</option>
      </select></label>
      <input id="slider" type="range" aria-label="simulation time">
      <span id="time"></span>
    </div>
  </section>
  <aside>
{live_panel}
    <h2>Ego</h2>
    <div id="readout"></div>
    <canvas id="vplot" width="340" height="100"></canvas>
    <canvas id="aplot" width="340" height="100"></canvas>
    <h2>Attached specification</h2>
    <pre id="spec"></pre>
    <div id="spec-version"></div>
    <h2>Legend</h2>
    <div class="legend">
      <span><i style="background:#16a34a"></i>ego</span><span><i style="background:#3b82f6"></i>car</span>
      <span><i style="background:#b45309"></i>truck</span><span><i style="background:#ca8a04"></i>bus</span>
      <span><i style="background:#dc2626"></i>emergency (flashing)</span>
      <span><i style="background:#374151"></i>stopped car</span>
      <span><i style="background:rgba(249,115,22,0.3);border-color:#f97316"></i>J2 disc</span>
      <span><i style="background:#d946ef"></i>MPPI plan</span>
      <span><i style="background:linear-gradient(90deg,#dc2626,#facc15,#22c55e)"></i>stop line, its light</span>
    </div>
    <h2>Messages and tool calls</h2>
    <ol id="log"></ol>
    <div id="notes"></div>
  </aside>
</main>
<script id="replay-data" type="application/json">{data}</script>
<script>
{js}
</script>
{live_js}
</body>
</html>
"""


LIVE_PANEL = """    <h2>Talk to the agent</h2>
    <form id="chat">
      <input id="chat-text" name="text" autocomplete="off" maxlength="2000"
             placeholder="e.g. an ambulance is coming, make way" aria-label="message to the agent">
      <button type="submit">Send</button>
    </form>
    <div id="chat-status" aria-live="polite"></div>
    <div id="connection"></div>"""
"""The live page's chat box (its messages go to the run's agent as the passenger's)."""


def _asset(name: str) -> str:
    return resources.files("agentic_mpc.replay").joinpath(name).read_text(encoding="utf-8")


def render_page(scene: dict[str, Any]) -> str:
    """The replay page of ``scene`` (from :func:`~agentic_mpc.replay.data.load_run`)."""
    data = json.dumps(scene, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    # Inside <script>, only "</" can end the element early; "<!--" could start an HTML comment state.
    data = data.replace("</", "<\\/").replace("<!--", "<\\!--")
    live_panel = live_js = ""
    if scene.get("live"):  # agentic-mpc serve --view: the chat box and the script that appends what is new
        live_panel, live_js = LIVE_PANEL, f"<script>\n{_asset('live.js')}\n</script>"
    return PAGE.format(title=html.escape(scene.get("title", "run")), css=_asset("replay.css"), js=_asset("replay.js"),
                       data=data, live_panel=live_panel, live_js=live_js)


def write_replay(run_dir: Path, out: Path | None = None) -> Path:
    """Write the replay page of the run in ``run_dir`` (default ``run_dir/replay.html``); returns its path.

    Raises :class:`~agentic_mpc.replay.data.ReplayInputError` when ``run_dir`` is not a readable run."""
    run_dir = Path(run_dir)
    out = Path(out) if out is not None else run_dir / REPLAY
    page = render_page(load_run(run_dir))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(page, encoding="utf-8")
    return out
