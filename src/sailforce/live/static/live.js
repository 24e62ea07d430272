// sail live: the page's side of the WebSocket (sailforce/live/server.py).  No library, nothing from the network.
"use strict";

// The server puts its token in the page only when the page is opened over a loopback address; elsewhere the
// user types the token that `sail live` printed (kept for this tab only).
let TOKEN = document.querySelector('meta[name="sail-token"]').content || sessionStorage.getItem("sail-token") || "";
const $ = (id) => document.getElementById(id);
const STATUS_CLASS = { ok: "ok", extrapolated: "warn", "motion-unknown": "warn", saturated: "bad", singular: "bad", invalid: "bad" };
const COLOURS = { fx: "#1f77b4", fy: "#d62728", f: "#222" };

let hello = null;          // the server's description of the arm and cells
let latest = null;         // the newest row
let points = [];           // [stamp s, fx, fy, |F|], the last history_s seconds
let dirty = false;
let recording = null;
let reportedFailure = null;
let socket = null;
let guide = null;          // the guided calibration's state (sail live --calibrate), or null
// Latency of each shown row: the page's clock when it drew the row, less the row's reading time [ms].
window.sailLatency = [];
const MAX_LATENCIES = 100000;

function fmt(value, digits) {
  return value === null || value === undefined ? "–" : value.toFixed(digits);
}

function setText(id, text) {
  const node = $(id);
  if (node.textContent !== text) node.textContent = text;
}

function connect() {
  socket = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  socket.onopen = () => { $("connection").textContent = "live"; $("connection").className = "badge on"; };
  socket.onclose = () => {
    $("connection").textContent = "reconnecting"; $("connection").className = "badge off";
    setTimeout(connect, 1000);
  };
  socket.onmessage = (event) => {
    const message = JSON.parse(event.data);
    if (message.type === "hello") onHello(message);
    else if (message.type === "update") onUpdate(message);
    else if (message.type === "result") onResult(message);
  };
}

function onHello(message) {
  hello = message;
  points = [];
  $("source").textContent = `${message.source}` + (message.calibration ? ` · ${message.calibration}` : "") +
    (message.dynamics ? " · dynamic term on" : "");
  showOffsets(message.offsets);
  $("guide-panel").hidden = !message.guide;
  dirty = true;
}

function showOffsets(offsets) {
  if (hello) setText("offsets", offsets.map((o) => o.toPrecision(7)).join(", ") + ` ${hello.load_unit}`);
}

function onUpdate(message) {
  const s = message.sample;
  if (s) {
    latest = s;
    setText("force-N", fmt(s.force_N, 2));
    setText("angle-deg", fmt(s.angle_deg, 1));
    setText("fx-N", fmt(s.fx_N, 2));
    setText("fy-N", fmt(s.fy_N, 2));
    setText("theta-deg", `${fmt(s.theta1_deg, 2)}, ${fmt(s.theta2_deg, 2)}`);
    // a real ADC's estimate refers to an instant before the row's tick: its age, t_s - force_t_s
    const multirate = s.force_t_s !== undefined;
    $("age-row").hidden = !multirate;
    if (multirate) setText("age-ms", s.force_t_s === null || s.t_s === null ? "–" : ((s.t_s - s.force_t_s) * 1e3).toFixed(0));
    setText("status", s.status);
    $("status").className = "status " + (STATUS_CLASS[s.status] || "");
    for (const i of [0, 1]) showCell(i, s.cells[i], s.status === "saturated");
  }
  for (const p of message.points) points.push(p);
  if (points.length) {
    const oldest = points[points.length - 1][0] - (hello ? hello.history_s : 10);
    let cut = 0;
    while (cut < points.length && points[cut][0] < oldest) cut++;
    if (cut) points.splice(0, cut);
  }
  setText("counts", Object.entries(message.counts).map(([k, v]) => `${k} ${v.toLocaleString()}`).join(" · ") || "–");
  setText("rate", `${Math.round(message.rate_hz)} rows/s` + (message.ended ? " · stream ended" : ""));
  showOffsets(message.offsets);
  recording = message.recording;
  const failed = message.recording_failed;
  if (failed && failed.file !== reportedFailure) {
    reportedFailure = failed.file;
    showMessage(`the recording stopped: ${failed.error}`, true);
  }
  $("record").textContent = recording ? "stop recording" : "record";
  $("record").classList.toggle("active", !!recording);
  setText("recording", recording ? `recording ${recording.file}: ${recording.rows.toLocaleString()} rows, ${recording.seconds.toFixed(0)} s` : "");
  if (message.error) showMessage(`the stream stopped: ${message.error}`, true);
  if (message.guide) showGuide(message.guide);
  dirty = true;
}

// The guided calibration: the hold to make, the phase it is in, and at the end the maps side by side.
function showGuide(g) {
  guide = g;
  $("guide-panel").hidden = false;
  setText("guide-count", `hold ${g.hold} of ${g.holds} · ${g.recorded} recorded` + (g.skipped ? ` · ${g.skipped} skipped` : ""));
  setText("guide-phase", g.phase);
  $("guide-phase").className = "badge " + g.phase;
  setText("guide-message", g.message);
  const t = g.target;
  setText("guide-theta1", t.theta1_deg.toFixed(1));
  setText("guide-theta2", t.theta2_deg.toFixed(1));
  setText("guide-mass", `${t.mass_kg}`);
  setText("guide-direction", t.direction_deg.toFixed(0));
  setText("guide-force", Math.hypot(t.fx_N, t.fy_N).toFixed(2));
  $("guide-progress").style.width = `${100 * (g.progress || 0)}%`;
  const ended = ["fitting", "done"].includes(g.phase);
  $("guide-skip").disabled = ended || g.phase === "failed";
  $("guide-redo").disabled = ended || g.recorded === 0;
  if (g.result) {
    const r = g.result;
    setText("guide-result", `calibrated from ${r.holds} holds: fit ${(1e3 * r.fit_rmse_N).toFixed(1)} mN RMS, ` +
      `cross-validated ${(1e3 * r.cv_rmse_N).toFixed(1)} mN; wrote ${r.recording}, ${r.calibration}, ${r.achieved}`);
    $("guide-map").hidden = false;
    drawGuideMap(r.map);
  } else {
    setText("guide-result", g.error || "");
  }
}

function drawGuideMap(map) {
  const canvas = $("guide-map"), g = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height, left = 56, right = 110, top = 12, bottom = 28;
  g.clearRect(0, 0, w, h);
  const curves = [[map.planned_N, "#6b7585", "planned"], [map.achieved_N, "#1b8a4b", "achieved"]].filter((c) => c[0]);
  let big = 0;
  for (const [values] of curves) for (const v of values) if (v > big) big = v;
  big = big > 0 ? big * 1e3 * 1.1 : 1;
  const d0 = map.delta_deg[0], d1 = map.delta_deg[map.delta_deg.length - 1];
  const px = (d) => left + (w - left - right) * (d - d0) / (d1 - d0);
  const py = (mN) => top + (h - top - bottom) * (1 - mN / big);
  g.strokeStyle = "#e3e7ee"; g.fillStyle = "#6b7585"; g.font = "12px system-ui"; g.lineWidth = 1;
  for (const f of [0, 0.5, 1]) {
    g.beginPath(); g.moveTo(left, py(f * big)); g.lineTo(w - right, py(f * big)); g.stroke();
    g.fillText(`${(f * big).toFixed(0)} mN`, 4, py(f * big) + 4);
  }
  for (let d = 30; d <= 150; d += 30) g.fillText(`${d}°`, px(d) - 10, h - 8);
  curves.forEach(([values, colour, label], row) => {
    g.strokeStyle = colour; g.lineWidth = 2; g.beginPath();
    values.forEach((v, i) => { const x = px(map.delta_deg[i]), y = py(v * 1e3); if (i) g.lineTo(x, y); else g.moveTo(x, y); });
    g.stroke();
    g.fillStyle = colour; g.fillText(label, w - right + 10, top + 16 + 18 * row);
  });
  g.fillStyle = "#6b7585"; g.fillText("worst force error against Δ", left, top + 2);
}

function showCell(i, fraction, saturated) {
  const bar = $(`cell${i + 1}-bar`);
  if (fraction === null) { bar.style.width = "0"; setText(`cell${i + 1}-pct`, "–"); return; }
  const f = Math.max(-1, Math.min(1, fraction));
  bar.style.left = `${50 + Math.min(0, f) * 50}%`;
  bar.style.width = `${Math.abs(f) * 50}%`;
  bar.classList.toggle("saturated", saturated || Math.abs(fraction) >= 1);
  setText(`cell${i + 1}-pct`, `${(fraction * 100).toFixed(1)} %`);
}

function showMessage(text, error) {
  $("message").textContent = text;
  $("message").className = "small" + (error ? " error" : "");
}

function onResult(message) {
  if (!message.ok) {
    if (/no valid token/.test(message.error) && !document.querySelector('meta[name="sail-token"]').content) {
      TOKEN = ""; sessionStorage.removeItem("sail-token");
    }
    showMessage(`${message.name}: ${message.error}`, true); return;
  }
  if (message.name === "tare") {
    const unit = message.unit;
    showMessage(`tared on ${message.samples} samples: offsets ${message.offsets.map((o) => o.toPrecision(7)).join(", ")} ${unit}` +
      ` (were ${message.previous.map((o) => o.toPrecision(7)).join(", ")}; spread ±${message.spread.map((o) => o.toPrecision(3)).join(", ±")}).` +
      (message.warnings.length ? " Warning: " + message.warnings.join(" ") : " Save calibration keeps them."), message.warnings.length > 0);
    showOffsets(message.offsets);
    $("save-calibration").disabled = false;
  } else if (message.name === "save-calibration") {
    showMessage(`saved ${message.file}`, false);
  } else if (message.name === "record") {
    if (message.stopped) showMessage(`recorded ${message.stopped}`, false);
  } else if (message.name === "guide-skip") {
    showMessage(message.skipped === "tare" ? "tare skipped" : `hold ${message.skipped} skipped`, false);
  } else if (message.name === "guide-redo") {
    showMessage(`redoing hold ${message.redo}`, false);
  }
}

function command(name, args) {
  if (!socket || socket.readyState !== WebSocket.OPEN) { showMessage("not connected", true); return; }
  if (!TOKEN) {
    TOKEN = (window.prompt("This page is not on this machine: enter the token that `sail live` printed") || "").trim();
    if (!TOKEN) { showMessage(`${name}: no token given`, true); return; }
    sessionStorage.setItem("sail-token", TOKEN);
  }
  socket.send(JSON.stringify(Object.assign({ type: "command", token: TOKEN, name }, args || {})));
}

$("tare").onclick = () => {
  const samples = parseInt($("tare-samples").value, 10);
  showMessage(`taring on the next ${samples} samples: do not touch the handle`, false);
  command("tare", { samples });
};
$("save-calibration").onclick = () => command("save-calibration");
$("record").onclick = () => command("record", { on: !recording });
$("guide-skip").onclick = () => command("guide-skip");
$("guide-redo").onclick = () => command("guide-redo");

// -- drawing ----------------------------------------------------------------------------------
function drawArm() {
  const canvas = $("arm"), g = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height;
  g.clearRect(0, 0, w, h);
  if (!hello) return;
  const arm = hello.arm, reach = arm.l2 + arm.l3;
  const scale = 0.46 * Math.min(w, h) / reach;       // px per m
  const x = (p) => w / 2 + p[0] * scale, y = (p) => h / 2 - p[1] * scale;
  g.strokeStyle = "#e3e7ee"; g.lineWidth = 1;
  g.beginPath(); g.arc(w / 2, h / 2, reach * scale, 0, 2 * Math.PI); g.stroke();
  g.beginPath(); g.moveTo(0, h / 2); g.lineTo(w, h / 2); g.moveTo(w / 2, 0); g.lineTo(w / 2, h); g.stroke();
  if (guide && !["done", "fitting"].includes(guide.phase)) {  // the hold's pose, and its weight's direction
    const t = guide.target.joints;
    g.setLineDash([6, 5]); g.strokeStyle = "#2e8b57"; g.lineWidth = 3;
    for (const [a, b] of [[t.B, t.P1], [t.B, t.P2], [t.P1, t.P3], [t.P2, t.A]]) {
      g.beginPath(); g.moveTo(x(a), y(a)); g.lineTo(x(b), y(b)); g.stroke();
    }
    g.setLineDash([]);
    const r = 40, a = guide.target.direction_deg * Math.PI / 180;
    arrow(g, x(t.A), y(t.A), x(t.A) + r * Math.cos(a), y(t.A) - r * Math.sin(a), "#2e8b57");
  }
  if (!latest || !latest.joints) return;
  const j = latest.joints;
  const link = (a, b, colour, width) => {
    g.strokeStyle = colour; g.lineWidth = width; g.lineCap = "round";
    g.beginPath(); g.moveTo(x(a), y(a)); g.lineTo(x(b), y(b)); g.stroke();
  };
  link(j.B, j.P1, "#5b6b82", 7);   // l1, driven by θ1
  link(j.B, j.P2, "#5b6b82", 7);   // l2, driven by θ2
  link(j.P1, j.P3, "#9aa6b8", 4);  // l4
  link(j.P2, j.A, "#9aa6b8", 5);   // l3 through P3 to A
  [[j.B, j.P1, 0], [j.B, j.P2, 1]].forEach(([a, b, i]) => {  // the cells, at mid-link
    const f = latest.cells[i], m = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2];
    g.fillStyle = f === null ? "#ccc" : Math.abs(f) >= 1 ? "#c0392b" : `hsl(${120 - 120 * Math.min(1, Math.abs(f))}, 70%, 42%)`;
    g.fillRect(x(m) - 7, y(m) - 7, 14, 14);
  });
  for (const p of [j.B, j.P1, j.P2, j.P3]) { g.fillStyle = "#1d2430"; g.beginPath(); g.arc(x(p), y(p), 4, 0, 2 * Math.PI); g.fill(); }
  g.fillStyle = "#1d2430"; g.beginPath(); g.arc(x(j.A), y(j.A), 7, 0, 2 * Math.PI); g.fill();
  if (latest.fx_N !== null && latest.fy_N !== null) {
    const nPerPx = arrowScale();
    const tip = [x(j.A) + latest.fx_N / nPerPx, y(j.A) - latest.fy_N / nPerPx];
    arrow(g, x(j.A), y(j.A), tip[0], tip[1], "#c0392b");
    setText("scale", `arrow: ${(60 * nPerPx).toFixed(0)} N per 60 px · circle: reach ${reach.toFixed(2)} m`);
  }
}

function arrowScale() {  // N per px: 60 px for the larger of 10 N and the largest |F| plotted
  let big = 10;
  for (const p of points) if (p[3] !== null && p[3] > big) big = p[3];
  return big / 60;
}

function arrow(g, x0, y0, x1, y1, colour) {
  const a = Math.atan2(y1 - y0, x1 - x0), len = Math.hypot(x1 - x0, y1 - y0);
  g.strokeStyle = colour; g.fillStyle = colour; g.lineWidth = 3;
  g.beginPath(); g.moveTo(x0, y0); g.lineTo(x1, y1); g.stroke();
  if (len < 4) return;
  g.beginPath(); g.moveTo(x1, y1);
  g.lineTo(x1 - 12 * Math.cos(a - 0.4), y1 - 12 * Math.sin(a - 0.4));
  g.lineTo(x1 - 12 * Math.cos(a + 0.4), y1 - 12 * Math.sin(a + 0.4));
  g.closePath(); g.fill();
}

function drawPlot() {
  const canvas = $("plot"), g = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height, left = 50, right = 90, top = 10, bottom = 24;
  g.clearRect(0, 0, w, h);
  if (!points.length || !hello) return;
  const span = hello.history_s, end = points[points.length - 1][0];
  let big = 5;
  for (const p of points) for (const v of [p[1], p[2], p[3]]) if (v !== null && Math.abs(v) > big) big = Math.abs(v);
  big = Math.ceil(big / 10) * 10;  // gridlines at whole multiples of 5 N
  const px = (t) => left + (w - left - right) * (1 - (end - t) / span);
  const py = (v) => top + (h - top - bottom) * (0.5 - v / (2 * big));
  g.strokeStyle = "#e3e7ee"; g.fillStyle = "#6b7585"; g.font = "12px system-ui"; g.lineWidth = 1;
  for (const v of [-big, -big / 2, 0, big / 2, big]) {
    g.beginPath(); g.moveTo(left, py(v)); g.lineTo(w - right, py(v)); g.stroke();
    g.fillText(`${v.toFixed(0)} N`, 4, py(v) + 4);
  }
  for (let s = 0; s <= span; s += 2) g.fillText(`-${s} s`, px(end - s) - 12, h - 6);
  [[1, "fx", "fx"], [2, "fy", "fy"], [3, "f", "|F|"]].forEach(([k, colour, label], row) => {
    g.strokeStyle = COLOURS[colour]; g.lineWidth = k === 3 ? 2 : 1.5; g.beginPath();
    let pen = false;
    for (const p of points) {
      if (p[k] === null) { pen = false; continue; }
      if (pen) g.lineTo(px(p[0]), py(p[k])); else g.moveTo(px(p[0]), py(p[k]));
      pen = true;
    }
    g.stroke();
    g.fillStyle = COLOURS[colour]; g.fillText(label, w - right + 10, top + 16 + 18 * row);
  });
}

function frame() {
  if (dirty) {
    dirty = false;
    drawArm();
    drawPlot();
    if (latest && latest.stamp && window.sailLatency.length < MAX_LATENCIES) window.sailLatency.push(Date.now() - latest.stamp * 1000);
  }
  requestAnimationFrame(frame);
}

connect();
requestAnimationFrame(frame);
