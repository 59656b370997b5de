// pointat's monitor: one WebSocket to the running patch ({"COMMAND": "MONITOR"}), drawn on canvases.
"use strict";
const COLOURS = ["#4fc3f7", "#ff8a65", "#ba68c8", "#aed581"];
const STALE = "#6b7078"; // a pointer with no fresh direction is drawn in this grey, dashed
const HISTORY = 10.0;
const state = { snap: null, history: {}, accel: {}, frames: 0, connected: false };
window.pointatMonitor = state; // for tests and the curious
let drawn = -1; // the frame last drawn

const $ = (id) => document.getElementById(id);
const rad = (d) => (d * Math.PI) / 180;
const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);

function take(snap, full) {
  state.snap = snap;
  state.frames += 1;
  if (full && snap.history) state.history = snap.history;
  if (full && snap.accel_history) state.accel = snap.accel_history;
  for (const p of snap.pointers) {
    const h = (state.history[p.name] ||= []);
    h.push([snap.t, p.azimuth, p.elevation, p.distance]);
    while (h.length && snap.t - h[0][0] > HISTORY) h.shift();
  }
  for (const [name, g] of Object.entries(snap.accel || {})) {
    const h = (state.accel[name] ||= []);
    h.push([snap.t, g]);
    while (h.length && snap.t - h[0][0] > HISTORY) h.shift();
  }
}

function connect() {
  const ws = new WebSocket(`ws://${location.host}/`);
  ws.onopen = () => { ws.send(JSON.stringify({ COMMAND: "MONITOR" })); setConn(true); };
  ws.onmessage = (ev) => { if (typeof ev.data === "string") take(JSON.parse(ev.data), false); };
  ws.onclose = () => { setConn(false); setTimeout(connect, 1000); };
}

function setConn(ok) {
  state.connected = ok;
  $("conn").textContent = ok ? "live" : "patch not reachable (stopped?) — retrying";
  $("conn").className = ok ? "ok" : "bad";
  drawn = -1; // redraw: what was shown is no longer live
}

// -- what is true now: a pointer with no fresh direction is stale, and said big ----------------------
// p.state: "waiting" (no direction yet), "ok", "dropout" (none for osc_out's dropout time), or a flag
function stale(p) { return !state.connected || p.state === "dropout" || p.state === "waiting"; }
function colour(p, k) { return stale(p) ? STALE : COLOURS[k % COLOURS.length]; }

// the worst of what is true now, as [state, class, title, detail] (null: all is well); the state is also
// the page's body[data-state], for the style sheet and for tests
function alertOf(snap) {
  if (!state.connected) return ["offline", "bad", "PATCH NOT REACHABLE", "the page shows the last it heard; it keeps trying"];
  const down = snap.pointers.filter((p) => p.state === "dropout");
  const silent = snap.streams.filter((s) => s.state === "dropout");
  if (down.length || silent.length) {
    const secs = Math.max(0, ...down.map((p) => p.silent_s), ...silent.map((s) => s.silent_s));
    const who = [...down.map((p) => p.name), ...silent.map((s) => s.name)].join(", ");
    return ["dropout", "bad", `NO DATA for ${secs.toFixed(1)} s`, `${who}: the glove is off, out of range or its battery flat; the directions shown are old`];
  }
  const waiting = snap.pointers.filter((p) => p.state === "waiting");
  if (waiting.length) {
    const nulls = (snap.nodes || []).some((n) => /calibrating/.test(n.text)) ? ": hold the glove still, its gyro nulls are being measured" : "";
    return ["waiting", "warn", "WAITING FOR DATA", `${waiting.map((p) => p.name).join(", ")}: no direction yet${nulls}`];
  }
  const troubled = Object.entries(snap.flags).filter(([, f]) => f.flag !== "ok");
  if (troubled.length) return ["flag", "warn", troubled.map(([n, f]) => `${n}: ${f.flag}`).join(" · "), "the filter's direction may be off while this lasts"];
  return null;
}

function drawAlert(snap) {
  const a = alertOf(snap), el = $("alert");
  document.body.dataset.state = a ? a[0] : "ok";
  if (!a) { el.hidden = true; return; }
  el.hidden = false; el.className = a[1];
  el.innerHTML = `${esc(a[2])}<small>${esc(a[3])}</small>`;
}

// -- views -------------------------------------------------------------------------------------------
function speakerXY(az, el, r) { return [-Math.sin(rad(az)) * Math.cos(rad(el)) * r, -Math.cos(rad(az)) * Math.cos(rad(el)) * r]; }

function drawAbove(snap) {
  const c = $("above"), g = c.getContext("2d"), W = c.width, R = W * 0.4;
  g.clearRect(0, 0, W, W); g.save(); g.translate(W / 2, W / 2);
  g.strokeStyle = "#333a44"; g.lineWidth = 1;
  for (const f of [1, 0.66, 0.33]) { g.beginPath(); g.arc(0, 0, R * f, 0, 2 * Math.PI); g.stroke(); }
  g.fillStyle = "#8a8f98"; g.font = "12px system-ui"; g.textAlign = "center";
  g.fillText("front", 0, -R - 22); g.fillText("left", -R - 26, 4); g.fillText("right", R + 28, 4);
  const L = snap.layout, first = snap.pointers[0], gains = first && !stale(first) ? first.gains : [];
  L.azimuths.forEach((az, i) => {
    const [x, y] = speakerXY(az, L.elevations[i], R), gain = gains[i] || 0;
    g.fillStyle = `rgba(240,180,41,${0.25 + 0.75 * gain})`;
    const s = 9 + 10 * gain; g.fillRect(x - s / 2, y - s / 2, s, s);
    g.fillStyle = "#e8e8e8"; g.fillText(String(i + 1), x, y - s / 2 - 4);
  });
  snap.pointers.forEach((p, k) => {
    const [x, y] = speakerXY(p.azimuth, p.elevation, R);
    g.strokeStyle = colour(p, k); g.fillStyle = g.strokeStyle; g.lineWidth = 4; g.setLineDash(stale(p) ? [8, 8] : []);
    g.beginPath(); g.moveTo(0, 0); g.lineTo(x, y); g.stroke();
    g.beginPath(); g.arc(x, y, 8, 0, 2 * Math.PI); g.fill();
  });
  g.setLineDash([]);
  if (snap.pointers.length && snap.pointers.every(stale)) {
    g.fillStyle = "#ef5350"; g.font = "bold 36px system-ui";
    g.fillText(state.connected && snap.pointers.some((p) => p.state === "dropout") ? "NO DATA" : state.connected ? "WAITING" : "OFFLINE", 0, 12);
  }
  g.restore();
}

function drawSide(snap) {
  const c = $("side"), g = c.getContext("2d"), W = c.width, H = c.height, R = Math.min(W / 2 - 30, H - 40);
  g.clearRect(0, 0, W, H); g.save(); g.translate(W / 2, H - 20);
  g.strokeStyle = "#333a44"; g.lineWidth = 1;
  g.beginPath(); g.arc(0, 0, R, Math.PI, 2 * Math.PI); g.stroke();
  g.beginPath(); g.moveTo(-R - 10, 0); g.lineTo(R + 10, 0); g.stroke();
  g.fillStyle = "#8a8f98"; g.font = "12px system-ui"; g.textAlign = "center";
  g.fillText("front", R - 10, 14); g.fillText("back", -R + 10, 14); g.fillText("up", 0, -R - 6);
  const L = snap.layout;
  L.azimuths.forEach((az, i) => {
    const x = Math.cos(rad(az)) * Math.cos(rad(L.elevations[i])) * R, y = -Math.sin(rad(L.elevations[i])) * R;
    g.fillStyle = "rgba(240,180,41,0.6)"; g.fillRect(x - 4, y - 4, 8, 8);
  });
  snap.pointers.forEach((p, k) => {
    const x = Math.cos(rad(p.azimuth)) * Math.cos(rad(p.elevation)) * R, y = -Math.sin(rad(p.elevation)) * R;
    g.strokeStyle = colour(p, k); g.fillStyle = g.strokeStyle; g.lineWidth = 4; g.setLineDash(stale(p) ? [8, 8] : []);
    g.beginPath(); g.moveTo(0, 0); g.lineTo(x, y); g.stroke();
    g.beginPath(); g.arc(x, y, 7, 0, 2 * Math.PI); g.fill();
  });
  g.setLineDash([]);
  g.restore();
}

function drawGains(snap) {
  const c = $("gains"), g = c.getContext("2d"), W = c.width, H = c.height;
  g.clearRect(0, 0, W, H);
  const n = snap.layout.azimuths.length, w = (W - 20) / Math.max(1, n);
  snap.pointers.forEach((p, k) => {
    p.gains.forEach((v, i) => {
      g.fillStyle = colour(p, k);
      const bw = (w - 6) / snap.pointers.length;
      g.fillRect(10 + i * w + k * bw, H - 20 - v * (H - 34), bw - 1, v * (H - 34));
    });
  });
  g.fillStyle = "#8a8f98"; g.font = "11px system-ui"; g.textAlign = "center";
  snap.layout.azimuths.forEach((az, i) => g.fillText(`${i + 1}: ${az}°`, 10 + i * w + w / 2, H - 6));
  $("layout-from").textContent = `(${n} loudspeakers, from ${snap.layout.from})`;
}

function plot(id, label, unit, series, lo, hi) {
  const c = $(id), g = c.getContext("2d"), W = c.width, H = c.height, t1 = state.snap.t, t0 = t1 - HISTORY;
  g.clearRect(0, 0, W, H);
  g.fillStyle = "#8a8f98"; g.font = "12px system-ui"; g.textAlign = "left"; g.fillText(`${label} (${unit})`, 8, 14);
  let min = lo, max = hi;
  for (const s of series) for (const v of s.points) { if (v[1] < min) min = v[1]; if (v[1] > max) max = v[1]; }
  const X = (t) => 50 + ((t - t0) / HISTORY) * (W - 60), Y = (v) => H - 10 - ((v - min) / (max - min || 1)) * (H - 30);
  g.strokeStyle = "#2a2e35"; g.beginPath(); g.moveTo(50, Y(0)); g.lineTo(W - 10, Y(0)); g.stroke();
  g.fillText(max.toFixed(0), 8, Y(max) + 4); g.fillText(min.toFixed(0), 8, Y(min));
  series.forEach((s, k) => {
    g.strokeStyle = COLOURS[k % COLOURS.length]; g.lineWidth = 2; g.beginPath();
    s.points.forEach((v, i) => (i ? g.lineTo(X(v[0]), Y(v[1])) : g.moveTo(X(v[0]), Y(v[1]))));
    g.stroke();
  });
}

function drawPlots() {
  const names = Object.keys(state.history), pick = (j) => names.map((n) => ({ points: state.history[n].map((h) => [h[0], h[j]]) }));
  plot("plot-az", "azimuth", "°, + left", pick(1), -30, 30);
  plot("plot-el", "elevation", "°, + up", pick(2), -20, 20);
  plot("plot-dist", "distance", "0 far .. 90 near", pick(3), 0, 90);
  plot("plot-acc", "acceleration", "g", Object.values(state.accel).map((h) => ({ points: h })), 0, 2);
}

// -- tables ------------------------------------------------------------------------------------------
function stateClass(s) { return s === "ok" ? "ok" : s === "waiting" ? "warn" : "bad"; }

function pointerWord(p) {
  if (!state.connected) return ["bad", "offline"];
  if (p.state === "dropout") return ["bad", `NO DATA ${p.silent_s.toFixed(1)} s`];
  if (p.state === "waiting") return ["warn", "waiting"];
  return p.state === "ok" ? ["ok", ""] : ["warn", p.state];
}

function drawTables(snap) {
  $("pointers").innerHTML = snap.pointers.map((p, k) => {
    const [cls, word] = pointerWord(p);
    return `<div class="pointer${stale(p) ? " stale" : ""}" data-state="${esc(p.state)}" style="color:${COLOURS[k % COLOURS.length]}">` +
    `<span data-name="${esc(p.name)}" class="aed">az ${p.azimuth.toFixed(1)}°  el ${p.elevation.toFixed(1)}°  dist ${p.distance.toFixed(0)}</span>` +
    `<span class="state ${cls}">${esc(word)}</span> ` +
    `<small>${esc(p.name)} → ${esc(p.about)}${p.updates !== undefined ? ` · ${p.updates} sent` : ""}${p.refused ? `; ${p.refused} refused: receiver not listening` : ""}</small></div>`;
  }).join("") || "<p>Nothing in this patch says where it points.</p>";
  $("sensors").tBodies[0].innerHTML = snap.streams.map((s) =>
    `<tr><td>${esc(s.name)} <small>(${esc(s.type)})</small></td><td class="${stateClass(s.state)}">${s.state === "dropout" ? "NO DATA " + s.silent_s.toFixed(1) + " s" : s.state}</td>` +
    `<td>${s.rate.toFixed(0)} Hz</td><td>${s.samples}</td><td>${s.dropouts}</td><td>${s.lost ?? "–"}</td></tr>`).join("");
  $("filters").tBodies[0].innerHTML = Object.entries(snap.flags).map(([name, f]) =>
    `<tr><td>${esc(name)}</td><td class="${f.flag === "ok" ? "ok" : "bad"}">${esc(f.flag)}${f.silent_s ? " " + f.silent_s.toFixed(1) + " s" : ""}</td><td>${f.resting ? "yes" : "no"}</td>` +
    `<td>${f.bias_dps !== undefined ? f.bias_dps.toFixed(2) + " °/s" : "–"}</td><td>${f.bias_learned_s !== undefined ? f.bias_learned_s.toFixed(0) + " s" : "–"}</td>` +
    `<td>${f.dip_deg != null ? f.dip_deg.toFixed(1) + "°" : "–"}</td></tr>`).join("");
  $("other").innerHTML = (snap.nodes || []).map((n) => `<p><b>${esc(n.name)}</b> ${esc(n.text)}</p>`).join("");
  $("events").innerHTML = snap.events.slice().reverse().map((e) => `<li>${e[0].toFixed(1)} s · ${esc(e[1])}: ${esc(e[2])}</li>`).join("");
}

function frame() {
  const snap = state.snap;
  if (snap && drawn !== state.frames) { // only when a reading came: the page costs nothing while idle
    drawn = state.frames;
    $("patch").textContent = snap.patch; $("about").textContent = snap.about;
    $("clock").textContent = `${snap.t.toFixed(0)} s`;
    drawAlert(snap); drawAbove(snap); drawSide(snap); drawGains(snap); drawTables(snap); drawPlots();
  }
  requestAnimationFrame(frame);
}

fetch("/monitor/state").then((r) => r.json()).then((snap) => take(snap, true)).catch(() => {}).finally(() => { connect(); frame(); });

// Another machine's monitor: host:port as pointat ls prints it (or the whole URL a patch printed, with its
// ?token=), opened in a tab of its own.  Only http: addresses with a port; that page is the other
// server's, and its own checks (Host, Origin, token) decide what it serves.
function elsewhereUrl(text) {
  text = text.trim();
  if (!/^https?:\/\//.test(text)) text = `http://${text}`;
  let url;
  try { url = new URL(text); } catch (e) { return null; }
  if (url.protocol !== "http:" || !url.port || url.username || url.password) return null;
  if (url.pathname === "/" || url.pathname === "") url.pathname = "/monitor";
  return url.href;
}

$("elsewhere").addEventListener("submit", (ev) => {
  ev.preventDefault();
  const url = elsewhereUrl($("elsewhere-host").value);
  $("elsewhere-why").textContent = url ? "" : "expected host:port, such as 192.168.1.20:9002";
  if (url) window.open(url, "_blank", "noopener");
});
