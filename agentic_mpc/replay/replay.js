// The replay page: plays the scene embedded in #replay-data (see agentic_mpc/replay/data.py).
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("replay-data").textContent);
  const track = D.ego.track, frames = D.traffic.frames, vehicles = D.traffic.vehicles;
  const T0 = track.length ? track[0][0] : 0;
  let T1 = track.length ? track[track.length - 1][0] : 0;
  let following = Boolean(D.live);  // a live page shows the newest time until the slider is moved back
  const HOLD_S = 6, MAX_CAPTIONS = 4;
  const COLOURS = {passenger: "#3b82f6", private: "#3b82f6", taxi: "#facc15", truck: "#b45309", trailer: "#92400e",
    bus: "#ca8a04", coach: "#ca8a04", delivery: "#0891b2", motorcycle: "#7c3aed", moped: "#7c3aed",
    bicycle: "#db2777"};
  const $ = (id) => document.getElementById(id);
  const view = $("view"), ctx = view.getContext("2d");
  const slider = $("slider"), playButton = $("play"), speedSelect = $("speed");
  let t = T0, playing = false, lastWall = null, scale = 7;  // scale: pixels per metre

  function lowerIndex(list, time, key) {  // last index with key(list[i]) <= time, or -1
    let lo = 0, hi = list.length - 1, best = -1;
    while (lo <= hi) {
      const mid = (lo + hi) >> 1;
      if (key(list[mid]) <= time) { best = mid; lo = mid + 1; } else { hi = mid - 1; }
    }
    return best;
  }
  function lerpAngle(a, b, f) {
    let d = b - a;
    while (d > Math.PI) d -= 2 * Math.PI;
    while (d < -Math.PI) d += 2 * Math.PI;
    return a + f * d;
  }
  function egoAt(time) {
    const i = Math.max(0, lowerIndex(track, time, (p) => p[0]));
    const p = track[i], q = track[Math.min(i + 1, track.length - 1)];
    const f = q[0] > p[0] ? Math.min(1, Math.max(0, (time - p[0]) / (q[0] - p[0]))) : 0;
    return {x: p[1] + f * (q[1] - p[1]), y: p[2] + f * (q[2] - p[2]), heading: lerpAngle(p[3], q[3], f),
      v: p[4] + f * (q[4] - p[4]), a: p[5] + f * (q[5] - p[5])};
  }
  function trafficAt(time) {  // [{vehicle, x, y, heading, speed}] interpolated between recorded frames
    const i = lowerIndex(frames, time, (fr) => fr[0]);
    if (i < 0) return [];
    const a = frames[i], b = frames[i + 1];
    const f = b && b[0] - a[0] < 1.0 ? (time - a[0]) / (b[0] - a[0]) : 0;
    const next = new Map();
    if (b && f > 0) for (const row of b[1]) next.set(row[0], row);
    return a[1].map((row) => {
      const n = next.get(row[0]);
      const g = n ? f : 0, m = n || row;
      return {vehicle: vehicles[row[0]], x: row[1] + g * (m[1] - row[1]), y: row[2] + g * (m[2] - row[2]),
        heading: lerpAngle(row[3], m[3], g), speed: row[4]};
    });
  }
  function planAt(time) {
    const i = lowerIndex(D.plan, time, (p) => p[0]);
    return i >= 0 && time - D.plan[i][0] < 1.0 ? D.plan[i] : null;
  }
  function specAt(time) {
    const specs = D.ego.specs;
    return specs[Math.max(0, lowerIndex(specs, time, (s) => s[0]))];
  }
  const SIGNAL_COLOURS = {red: "#dc2626", yellow: "#facc15", green: "#22c55e", off: "#9ca3af"};
  D.signals = D.signals || [];
  function signalsAt(time) {  // [{id, state, x, y, heading}] of the lights the ego sees at this time
    const shown = [];
    for (const j of D.signals) {
      const i = lowerIndex(j.changes, time, (c) => c[0]);
      if (i >= 0 && j.changes[i][1] in SIGNAL_COLOURS) {
        const c = j.changes[i];
        shown.push({id: j.id, state: c[1], x: c[2], y: c[3], heading: c[4]});
      }
    }
    return shown;
  }
  function captionsAt(time) {
    return D.captions.filter((c) => c.t <= time + 1e-9 && time < c.t + HOLD_S).slice(-MAX_CAPTIONS);
  }

  // --- drawing --------------------------------------------------------------------------------------
  function resize() {
    const box = view.parentElement.getBoundingClientRect();
    const ratio = window.devicePixelRatio || 1;
    view.width = Math.max(200, Math.floor(box.width * ratio));
    view.height = Math.max(200, Math.floor(box.height * ratio));
    view.style.width = box.width + "px";
    view.style.height = box.height + "px";
  }
  function polyline(points, toScreen) {
    ctx.beginPath();
    points.forEach((p, k) => { const s = toScreen(p[0], p[1]); if (k) ctx.lineTo(s[0], s[1]); else ctx.moveTo(s[0], s[1]); });
    ctx.stroke();
  }
  function inView(line, ego, w, h, px) {  // whether a polyline's bounding box (worked out once) is on screen
    if (!line.box) {
      const xs = line.map((p) => p[0]), ys = line.map((p) => p[1]);
      line.box = [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)];
    }
    const b = line.box, mx = w / 2 / px + 10, my = h / 2 / px + 10;
    return b[2] > ego.x - mx && b[0] < ego.x + mx && b[3] > ego.y - my && b[1] < ego.y + my;
  }
  function drawNetwork(net, ego, w, h, px, toScreen) {  // the streets and junctions around the route
    const shown = (line) => inView(line, ego, w, h, px);
    ctx.strokeStyle = "#4b5563"; ctx.fillStyle = "#4b5563"; ctx.lineCap = "butt";
    for (const [width, lines] of net.lanes) {
      ctx.lineWidth = width * px * 1.02;
      lines.filter(shown).forEach((line) => polyline(line, toScreen));
    }
    for (const ring of net.junctions.filter(shown)) {
      ctx.beginPath();
      ring.forEach((p, k) => { const s = toScreen(p[0], p[1]); if (k) ctx.lineTo(s[0], s[1]); else ctx.moveTo(s[0], s[1]); });
      ctx.closePath(); ctx.fill(); ctx.lineWidth = 1; ctx.stroke();
    }
    ctx.lineCap = "round";
    ctx.strokeStyle = "rgba(255,255,255,0.7)"; ctx.lineWidth = Math.max(1, 0.12 * px);
    ctx.setLineDash([3 * px, 6 * px]);
    net.dividers.filter(shown).forEach((line) => polyline(line, toScreen));
    ctx.setLineDash([]);
  }
  function stopLine(s, heading, width, colour, px) {  // a bar across the ego's lane at a traffic light
    ctx.save();
    ctx.translate(s[0], s[1]);
    ctx.rotate(-heading);
    ctx.fillStyle = colour; ctx.strokeStyle = "#111827"; ctx.lineWidth = Math.max(1, 0.06 * px);
    ctx.fillRect(-0.4 * px, -width * px / 2, 0.8 * px, width * px);
    ctx.strokeRect(-0.4 * px, -width * px / 2, 0.8 * px, width * px);
    ctx.restore();
  }
  function footprint(s, heading, L, W, fill, outline, px) {
    ctx.save();
    ctx.translate(s[0], s[1]);
    ctx.rotate(-heading);
    ctx.fillStyle = fill;
    ctx.strokeStyle = outline;
    ctx.lineWidth = Math.max(1, 0.08 * px);
    ctx.fillRect(-L * px / 2, -W * px / 2, L * px, W * px);
    ctx.strokeRect(-L * px / 2, -W * px / 2, L * px, W * px);
    ctx.fillStyle = "rgba(255,255,255,0.75)";  // windscreen: shows which way it faces
    ctx.fillRect(L * px * 0.12, -W * px * 0.38, L * px * 0.14, W * px * 0.76);
    ctx.restore();
  }
  function draw() {
    const ratio = window.devicePixelRatio || 1, px = scale * ratio;
    const w = view.width, h = view.height, ego = egoAt(t);
    const toScreen = (x, y) => [w / 2 + (x - ego.x) * px, h / 2 - (y - ego.y) * px];
    const visible = (x, y, r) => Math.abs(x - ego.x) * px < w / 2 + r * px && Math.abs(y - ego.y) * px < h / 2 + r * px;
    ctx.fillStyle = "#7fa36b";
    ctx.fillRect(0, 0, w, h);
    const road = D.road;
    ctx.lineCap = "round"; ctx.lineJoin = "round";
    if (road.network) drawNetwork(road.network, ego, w, h, px, toScreen);
    if (road.lanes) {
      ctx.strokeStyle = "#4b5563"; ctx.lineWidth = road.lane_width_m * px * 1.02;
      road.lanes.forEach((line) => polyline(line, toScreen));
      ctx.strokeStyle = "rgba(255,255,255,0.9)"; ctx.lineWidth = Math.max(1, 0.15 * px);
      ctx.setLineDash([3 * px, 6 * px]);
      road.boundaries.forEach((line) => polyline(line, toScreen));
      ctx.setLineDash([]);
      road.edges.forEach((side) => side.forEach((line) => polyline(line, toScreen)));
      ctx.strokeStyle = "rgba(255,255,255,0.08)"; ctx.lineWidth = 1;
      ctx.setLineDash([1 * px, 2 * px]);
      road.lanes.forEach((line) => polyline(line, toScreen));
      ctx.setLineDash([]);
    }
    const signals = signalsAt(t);
    for (const light of signals) {
      stopLine(toScreen(light.x, light.y), light.heading, road.lane_width_m || 3.2, SIGNAL_COLOURS[light.state], px);
    }
    const drawn = ["ego"];
    for (const o of D.obstacles) {
      ctx.strokeStyle = "#f97316"; ctx.fillStyle = "rgba(249,115,22,0.18)"; ctx.lineWidth = Math.max(1, 0.12 * px);
      ctx.setLineDash([0.6 * px, 0.4 * px]);
      for (const d of o.discs) {
        const s = toScreen(d[0], d[1]);
        ctx.beginPath(); ctx.arc(s[0], s[1], d[2] * px, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      }
      ctx.setLineDash([]);
      if (o.car) footprint(toScreen(o.car[0], o.car[1]), o.car[2], o.car[3], o.car[4], "#374151", "#111827", px);
      const first = o.discs[0];
      if (first && visible(first[0], first[1], 10)) drawn.push(o.id);
    }
    const plan = planAt(t);
    if (plan) {
      ctx.strokeStyle = "#d946ef"; ctx.lineWidth = Math.max(1.5, 0.25 * px);
      if (plan[1].length > 1) polyline(plan[1], toScreen);
      ctx.fillStyle = "#f5d0fe";
      for (const r of plan[2]) { const s = toScreen(r[0], r[1]); ctx.fillRect(s[0] - 2, s[1] - 2, 4, 4); }
    }
    const flash = Math.floor(performance.now() / 250) % 2 === 0;
    for (const car of trafficAt(t)) {
      const v = car.vehicle;
      if (!visible(car.x, car.y, v.L)) continue;
      drawn.push(v.id);
      const fill = v.em ? (flash ? "#dc2626" : "#f8fafc") : (COLOURS[v.cls] || "#64748b");
      footprint(toScreen(car.x, car.y), car.heading, v.L, v.W, fill, v.em ? "#1d4ed8" : "#0f172a", px);
      if (v.em) {  // the light bar flashes blue/red
        const s = toScreen(car.x, car.y);
        ctx.fillStyle = flash ? "#2563eb" : "#dc2626";
        ctx.beginPath(); ctx.arc(s[0], s[1], Math.max(3, 0.45 * px), 0, 2 * Math.PI); ctx.fill();
      }
      if (scale >= 5) {
        ctx.fillStyle = "#111827"; ctx.font = `${Math.round(11 * ratio)}px sans-serif`;
        const s = toScreen(car.x, car.y);
        ctx.fillText(v.id, s[0] + v.W * px * 0.6, s[1] - v.W * px * 0.8);
      }
    }
    footprint(toScreen(ego.x, ego.y), ego.heading, D.ego.L, D.ego.W, "#16a34a", "#052e16", px);
    ctx.fillStyle = "rgba(17,24,39,0.75)"; ctx.fillRect(8 * ratio, 8 * ratio, 300 * ratio, 24 * ratio);  // scale bar
    ctx.fillStyle = "#fff"; ctx.font = `${Math.round(12 * ratio)}px sans-serif`;
    ctx.fillRect(16 * ratio, 22 * ratio, 10 * px, 3 * ratio);
    ctx.fillText(`10 m    t = ${t.toFixed(2)} s    v = ${ego.v.toFixed(1)} m/s`, 20 * ratio + 10 * px, 26 * ratio);
    return {ego, drawn, signals: signals.map((light) => ({id: light.id, state: light.state}))};
  }

  // --- side panel -----------------------------------------------------------------------------------
  function miniPlot(canvas, column, label, unit, colour) {
    const c = canvas.getContext("2d"), w = canvas.width, h = canvas.height, pad = 26;
    const values = track.map((p) => p[column]).filter((v) => v !== null);
    let lo = Math.min(0, ...values), hi = Math.max(...values, lo + 1e-3);
    const tx = (time) => pad + (time - T0) / Math.max(T1 - T0, 1e-9) * (w - pad - 6);
    const ty = (v) => h - 14 - (v - lo) / (hi - lo) * (h - 30);
    c.clearRect(0, 0, w, h);
    c.strokeStyle = "#e5e7eb"; c.beginPath(); c.moveTo(pad, ty(0)); c.lineTo(w - 6, ty(0)); c.stroke();
    c.strokeStyle = colour; c.lineWidth = 1.5; c.beginPath();
    track.forEach((p, k) => { if (p[column] === null) return; if (k) c.lineTo(tx(p[0]), ty(p[column])); else c.moveTo(tx(p[0]), ty(p[column])); });
    c.stroke();
    c.fillStyle = "#374151"; c.font = "11px sans-serif";
    c.fillText(`${label} [${unit}]`, pad, 11);
    c.fillText(hi.toFixed(1), 0, ty(hi) + 4); c.fillText(lo.toFixed(1), 0, ty(lo));
    for (const cap of D.captions) if (cap.kind === "tool") { c.fillStyle = "#d946ef"; c.fillRect(tx(cap.t), h - 12, 2, 8); }
    c.strokeStyle = "#dc2626"; c.lineWidth = 1; c.beginPath(); c.moveTo(tx(t), 14); c.lineTo(tx(t), h - 12); c.stroke();
    canvas.onclick = (e) => { const r = canvas.getBoundingClientRect(); seek(T0 + (e.clientX - r.left - pad) / (r.width - pad - 6) * (T1 - T0)); };
  }
  function buildLog(from = 0) {
    const log = $("log");
    D.captions.slice(from).forEach((c, j) => {
      const k = from + j;
      const item = document.createElement("li");
      item.className = "cap-" + c.kind;
      item.dataset.k = k;
      item.textContent = `${c.t.toFixed(2)} s  ${c.kind}: ${c.text}`;
      item.onclick = () => seek(c.t);
      log.appendChild(item);
    });
  }
  function updatePanel(ego) {
    const spec = specAt(t);
    $("spec").textContent = spec ? spec[2].split(/;\s*/).join("\n") : "";
    $("spec-version").textContent = spec ? `version ${spec[1]} since ${spec[0].toFixed(2)} s` : "";
    $("readout").textContent = `v ${ego.v.toFixed(1)} m/s (${(ego.v * 3.6).toFixed(0)} km/h)   a ${ego.a.toFixed(2)} m/s²`;
    miniPlot($("vplot"), 4, "speed", "m/s", "#16a34a");
    miniPlot($("aplot"), 5, "acceleration", "m/s²", "#2563eb");
    document.querySelectorAll("#log li").forEach((li) => li.classList.toggle("past", D.captions[li.dataset.k].t <= t));
  }
  function render() {
    if (!track.length) {  // a live page opened before the first control step: nothing to draw yet
      window.replayState = {t, t0: T0, t1: T1, playing, live: Boolean(D.live), following, drawn: [], captions: [], spec: ""};
      return;
    }
    const {ego, drawn, signals} = draw();
    const shown = captionsAt(t);
    const box = $("captions");
    box.replaceChildren(...shown.map((c) => {
      const div = document.createElement("div");
      div.className = "caption cap-" + c.kind;
      div.textContent = ({passenger: "Passenger: ", observation: "Observation: ", agent: "Agent: ", tool: "Tool call: ",
        stuck: "Stuck: "})[c.kind] + c.text;
      return div;
    }));
    slider.value = t;
    $("time").textContent = D.live && following ? `${t.toFixed(2)} s (live)` : `${t.toFixed(2)} / ${T1.toFixed(2)} s`;
    updatePanel(ego);
    window.replayState = {t, t0: T0, t1: T1, playing, live: Boolean(D.live), following, speed: Number(speedSelect.value), scale,
      ego: {x: ego.x, y: ego.y, heading: ego.heading, v: ego.v, a: ego.a}, drawn, signals,
      captions: shown.map((c) => c.text), spec: specAt(t) ? specAt(t)[2] : ""};
  }
  function seek(time) {
    t = Math.min(T1, Math.max(T0, Number(time)));
    render();
    return window.replayState;
  }
  function setPlaying(on) {
    playing = on && t < T1;
    playButton.textContent = playing ? "❚❚ Pause" : "▶ Play";
    lastWall = null;
    if (playing) requestAnimationFrame(tick); else render();
  }
  function tick(now) {
    if (!playing) return;
    if (lastWall !== null) t = Math.min(T1, t + (now - lastWall) / 1000 * Number(speedSelect.value));
    lastWall = now;
    render();
    if (t >= T1) setPlaying(false); else requestAnimationFrame(tick);
  }

  document.title = "Replay: " + D.title;
  $("title").textContent = D.title;
  $("description").textContent = D.description;
  const s = D.summary;
  $("summary").textContent = Object.keys(s).length ? ["status", "collisions", "mean_speed_mps", "ambulance_delay_s", "agent_tool_calls"]
    .filter((k) => k in s && s[k] !== "").map((k) => `${k} ${s[k]}`).join(" · ") : "";
  $("notes").textContent = D.notes.join("; ");
  slider.min = T0; slider.max = T1; slider.step = 0.01;
  slider.oninput = () => {
    const value = Number(slider.value);
    playing = false; playButton.textContent = "▶ Play";
    following = Boolean(D.live) && value >= T1 - 0.05;
    seek(value);
  };
  function append(chunk) {  // a live page: what the run recorded since the last chunk (agentic_mpc/replay/live.py)
    track.push(...chunk.track); frames.push(...chunk.frames); vehicles.push(...chunk.vehicles);
    D.ego.specs.push(...chunk.specs);
    for (const [id, ...change] of chunk.signals || []) {  // [junction id, t, state, x, y, heading]
      let junction = D.signals.find((j) => j.id === id);
      if (!junction) { junction = {id, changes: []}; D.signals.push(junction); }
      junction.changes.push(change);
    }
    const before = D.captions.length;
    D.captions.push(...chunk.captions);
    buildLog(before);
    if (track.length) T1 = track[track.length - 1][0];
    slider.max = T1;
    if (following) t = T1;
    if (!playing) render();
    return window.replayState;
  }
  window.replayAppend = append;
  playButton.onclick = () => { if (t >= T1) t = T0; setPlaying(!playing); };
  $("zoom-in").onclick = () => { scale = Math.min(40, scale * 1.25); render(); };
  $("zoom-out").onclick = () => { scale = Math.max(0.5, scale / 1.25); render(); };
  view.addEventListener("wheel", (e) => { e.preventDefault(); scale = Math.min(40, Math.max(0.5, scale * (e.deltaY < 0 ? 1.1 : 1 / 1.1))); render(); }, {passive: false});
  document.addEventListener("keydown", (e) => {
    if (e.target.tagName === "SELECT") return;
    if (e.key === " ") { e.preventDefault(); playButton.onclick(); }
    if (e.key === "ArrowRight") seek(t + 1);
    if (e.key === "ArrowLeft") seek(t - 1);
  });
  window.addEventListener("resize", () => { resize(); render(); });
  setInterval(() => { if (!playing && vehicles.some((v) => v.em)) draw(); }, 250);  // keep the lights flashing
  window.replaySeek = seek;
  window.replayPlay = setPlaying;
  buildLog();
  resize();
  seek(D.live ? T1 : T0);
})();
