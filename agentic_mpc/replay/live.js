// The live page (agentic-mpc serve --view): appends what the run records (server-sent events from /events)
// and sends the chat box's messages to the run's agent (POST /chat). Same origin, so the session cookie of a
// token-protected server goes along.
(function () {
  "use strict";
  const $ = (id) => document.getElementById(id);
  const D = JSON.parse(document.getElementById("replay-data").textContent);
  const counts = {track: D.ego.track.length, frames: D.traffic.frames.length, vehicles: D.traffic.vehicles.length,
    specs: D.ego.specs.length, captions: D.captions.length,
    signals: (D.signals || []).reduce((n, j) => n + j.changes.length, 0)};
  const connection = $("connection");
  window.liveState = {chunks: 0, sent: 0, ended: false};
  const source = new EventSource("events?" + new URLSearchParams(counts));
  source.addEventListener("chunk", (e) => {
    window.replayAppend(JSON.parse(e.data));
    window.liveState.chunks += 1;
    connection.textContent = "live"; connection.className = "";
  });
  source.addEventListener("end", (e) => {
    window.liveState.ended = true;
    connection.textContent = "the run has ended: " + e.data; connection.className = "";
    source.close();
  });
  source.onerror = () => {
    if (!window.liveState.ended) { connection.textContent = "connection lost; retrying"; connection.className = "error"; }
  };
  $("chat").addEventListener("submit", async (e) => {
    e.preventDefault();
    const input = $("chat-text"), status = $("chat-status"), text = input.value.trim();
    if (!text) return;
    status.className = ""; status.textContent = "sending…";
    try {
      const response = await fetch("chat", {method: "POST", headers: {"content-type": "application/json"},
        body: JSON.stringify({text})});
      const answer = await response.json().catch(() => ({error: response.statusText}));
      if (!response.ok) throw new Error(answer.error || response.statusText);
      input.value = "";
      window.liveState.sent += 1;
      status.textContent = `sent at t = ${answer.sim_time_s.toFixed(2)} s; the agent answers in its own time`;
    } catch (error) {
      status.className = "error"; status.textContent = "not sent: " + error.message;
    }
  });
})();
