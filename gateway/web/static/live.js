// CORNET live view: draws what /events streams (gateway/web/server.py, docs/web.md).
// No library, no build: a canvas map (north up, metres east/north of the world's home), a side
// panel (every vehicle and link, their values also in data-* attributes), a timeline canvas.
"use strict";

const view = { frame: null, trails: new Map(), thresholds: null };
const $ = (id) => document.getElementById(id);
const css = (name) => getComputedStyle(document.documentElement).getPropertyValue(name).trim();
const REASON_COLOURS = { loss: "#d7263d", outage: "#7a0f1c", range: "#ff7f0e", queue: "#e0a100",
                         late: "#7b3fbf" };

function fmt(x, digits) {
  if (x === null || x === undefined) return "–";
  const text = Number(x).toFixed(digits);
  return /^-0(\.0+)?$/.test(text) ? text.slice(1) : text;  // no "-0.0"
}

// --- the stream ----------------------------------------------------------------------------
function connect() {
  const source = new EventSource("/events");
  const connection = $("connection");
  source.addEventListener("snapshot", (e) => {
    const snap = JSON.parse(e.data);
    view.trails = new Map(Object.entries(snap.trails || {}).map(([k, v]) => [Number(k), v]));
    apply(snap);
  });
  source.addEventListener("frame", (e) => apply(JSON.parse(e.data)));
  source.onopen = () => { connection.dataset.state = "live"; connection.textContent = "live"; };
  source.onerror = () => {
    connection.dataset.state = "lost";
    connection.textContent = "disconnected: retrying…";
  };
}

function apply(frame) {
  view.frame = frame;
  view.thresholds = frame.thresholds || view.thresholds;
  const step = view.thresholds ? view.thresholds.trail_step_m : 0.5;
  const keep = view.thresholds ? view.thresholds.trail_points : 400;
  for (const v of frame.vehicles) {
    const [n, e] = v.world_ned_m;
    let trail = view.trails.get(v.sysid);
    if (!trail) { trail = []; view.trails.set(v.sysid, trail); }
    const last = trail[trail.length - 1];
    if (!last || Math.hypot(n - last[0], e - last[1]) >= step) trail.push([n, e]);
    if (trail.length > keep) trail.splice(0, trail.length - keep);
  }
  renderHeader(frame);
  renderVehicles(frame);
  renderLinks(frame);
  renderLegend();
  renderEvents(frame);
  requestAnimationFrame(draw);
}

// --- the panel -----------------------------------------------------------------------------
function renderHeader(frame) {
  if (frame.server) $("source").textContent = `from ${frame.server.source}`;
  const clock = $("clock");
  clock.dataset.t = frame.t === null ? "" : String(frame.t);
  clock.textContent = frame.t === null ? "sim t = – (waiting for the simulation)"
    : `sim t = ${fmt(frame.t, 1)} s`;
  if (frame.home) {
    $("home").textContent = `home ${fmt(frame.home.lat_deg, 6)}, ${fmt(frame.home.lon_deg, 6)}`;
  }
}

function keyed(list, key, make) {
  let el = list.querySelector(`[data-key="${CSS.escape(key)}"]`);
  if (!el) { el = make(); el.dataset.key = key; list.appendChild(el); }
  return el;
}

function prune(list, keys) {
  for (const el of [...list.children]) if (!keys.has(el.dataset.key)) el.remove();
}

function renderVehicles(frame) {
  const list = $("vehicles");
  const keys = new Set();
  for (const v of frame.vehicles) {
    const key = String(v.sysid);
    keys.add(key);
    const li = keyed(list, key, () => {
      const li = document.createElement("li");
      li.className = "vehicle";
      li.innerHTML = '<span class="name"></span> <span class="mode"></span> · ' +
        '<span class="arming"></span> · <span class="alt"></span> · <span class="battery"></span>' +
        '<br><small class="where"></small>';
      return li;
    });
    const [n, e] = v.world_ned_m;
    const alt = v.rel_alt_m === null ? -v.world_ned_m[2] : v.rel_alt_m;
    Object.assign(li.dataset, { sysid: key, north: fmt(n, 2), east: fmt(e, 2), alt: fmt(alt, 2),
                                mode: v.mode, armed: String(v.armed) });
    li.querySelector(".name").textContent = `vehicle ${v.sysid}`;
    li.querySelector(".mode").textContent = v.mode + (v.failsafe ? " (failsafe)" : "");
    const arming = li.querySelector(".arming");
    arming.textContent = v.armed ? "armed" : "disarmed";
    arming.classList.toggle("is-armed", v.armed);
    li.querySelector(".alt").textContent = `alt ${fmt(alt, 1)} m`;
    li.querySelector(".battery").textContent = `battery ${fmt(100 * v.battery_remaining, 0)} %`;
    li.querySelector(".where").textContent =
      `N ${fmt(n, 1)} m, E ${fmt(e, 1)} m · ${fmt(v.lat_deg, 7)}, ${fmt(v.lon_deg, 7)} · ` +
      `${v.landed_state.toLowerCase().replace("_", " ")}`;
  }
  prune(list, keys);
}

function renderLinks(frame) {
  const list = $("links");
  const keys = new Set();
  for (const l of frame.links) {
    keys.add(l.link);
    const li = keyed(list, l.link, () => {
      const li = document.createElement("li");
      li.innerHTML = '<span class="swatch"></span><span class="text"></span>';
      return li;
    });
    li.className = `link state-${l.state}`;
    Object.assign(li.dataset, { link: l.link, state: l.state, loss: String(l.loss),
                                latencyMs: l.latency_ms === null ? "" : String(l.latency_ms) });
    const drops = Object.entries(l.dropped).map(([k, v]) => `${k} ${v}`).join(", ");
    li.querySelector(".text").textContent =
      `${l.link} · ${l.state} · loss ${fmt(100 * l.loss, 0)} % · ${fmt(l.latency_ms, 1)} ms · ` +
      `${l.delivered}/${l.sent}` + (drops ? ` · dropped: ${drops}` : "") +
      (l.late ? ` · late ${l.late}` : "");
  }
  prune(list, keys);
}

function renderLegend() {
  const th = view.thresholds;
  if (!th) return;
  $("legend-good").textContent =
    `(loss < ${100 * th.good_loss} %, latency < ${th.good_latency_ms} ms)`;
  $("legend-degraded").textContent =
    `(loss ≥ ${100 * th.good_loss} % or latency ≥ ${th.good_latency_ms} ms)`;
  $("legend-lost").textContent = `(loss ≥ ${100 * th.lost_loss} %)`;
}

function renderEvents(frame) {
  const list = $("events");
  list.replaceChildren(...frame.events.slice().reverse().map((ev) => {
    const li = document.createElement("li");
    li.className = ev.kind === "link" ? `link-${ev.state}` : ev.kind;
    li.textContent = `t = ${fmt(ev.t, 1)} s  ${ev.text}`;
    return li;
  }));
}

// --- the map -------------------------------------------------------------------------------
function sized(canvas) {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  if (canvas.width !== Math.round(r.width * dpr) || canvas.height !== Math.round(r.height * dpr)) {
    canvas.width = Math.round(r.width * dpr);
    canvas.height = Math.round(r.height * dpr);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  return [ctx, r.width, r.height];
}

function fit(frame, w, h) {
  // Every vehicle, its trail, every ground node and home, at least 20 m across, inside margins
  // that leave room for the labels (right and below) and the scale bar.
  const pts = [[0, 0]];
  for (const v of frame.vehicles) pts.push(v.world_ned_m);
  for (const t of view.trails.values()) for (const p of t) pts.push(p);
  for (const node of frame.nodes) pts.push(node.world_ned_m);
  let [n0, n1, e0, e1] = [Infinity, -Infinity, Infinity, -Infinity];
  for (const [n, e] of pts) { n0 = Math.min(n0, n); n1 = Math.max(n1, n); e0 = Math.min(e0, e); e1 = Math.max(e1, e); }
  const box = { left: 40, right: w - 190, top: 40, bottom: h - 90 };
  const bw = Math.max(box.right - box.left, 50), bh = Math.max(box.bottom - box.top, 50);
  const scale = Math.min(bw / Math.max(e1 - e0, 20), bh / Math.max(n1 - n0, 20));  // px per metre
  const cn = (n0 + n1) / 2, ce = (e0 + e1) / 2;
  const cx = box.left + bw / 2, cy = box.top + bh / 2;
  return { scale, xy: (n, e) => [cx + (e - ce) * scale, cy - (n - cn) * scale],
           ne: (x, y) => [cn - (y - cy) / scale, ce + (x - cx) / scale] };
}

function niceLength(m) {
  const p = Math.pow(10, Math.floor(Math.log10(m)));
  for (const k of [5, 2, 1]) if (k * p <= m) return k * p;
  return p;
}

function nodeFor(frame, sysid, tag) {
  const candidates = frame.nodes.filter((node) => node.serves.includes(tag));
  if (candidates.length <= 1) return candidates[0] || null;
  const serving = frame.serving[`v${sysid}`];
  const named = candidates.find((node) => node.name === serving);
  if (named) return named;
  const v = frame.vehicles.find((x) => x.sysid === sysid);
  if (!v) return candidates[0];
  const d = (node) => Math.hypot(node.world_ned_m[0] - v.world_ned_m[0], node.world_ned_m[1] - v.world_ned_m[1]);
  return candidates.reduce((a, b) => (d(a) <= d(b) ? a : b));
}

function draw() {
  const frame = view.frame;
  if (!frame) return;
  const [ctx, w, h] = sized($("map"));
  ctx.clearRect(0, 0, w, h);
  const { scale, xy, ne } = fit(frame, w, h);
  view.ne = ne;
  const colour = (state) => css(`--${state}`) || "#999";
  const byId = new Map(frame.vehicles.map((v) => [v.sysid, v]));
  // home
  const [hx, hy] = xy(0, 0);
  ctx.strokeStyle = "#888"; ctx.lineWidth = 1;
  ctx.beginPath(); ctx.moveTo(hx - 6, hy); ctx.lineTo(hx + 6, hy); ctx.moveTo(hx, hy - 6); ctx.lineTo(hx, hy + 6); ctx.stroke();
  ctx.fillStyle = "#888"; ctx.font = "11px system-ui"; ctx.fillText("home", hx + 8, hy + 12);
  // trails
  ctx.strokeStyle = "rgba(40, 110, 200, 0.45)"; ctx.lineWidth = 2;
  for (const [sysid, trail] of view.trails) {
    if (!byId.has(sysid) || trail.length < 2) continue;
    ctx.beginPath();
    trail.forEach(([n, e], i) => { const [x, y] = xy(n, e); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    ctx.stroke();
  }
  // radio links: vehicle to the node its hop ends at, in the worst state of the links over
  // that hop (gcs and api share an access point's); links with no such node (direct links):
  // a ring around the vehicle, in the worst state of those
  const severity = { idle: 0, good: 1, degraded: 2, lost: 3 };
  const worse = (a, b) => (a === undefined || severity[b] > severity[a] ? b : a);
  const hops = new Map();
  const rings = new Map();
  for (const l of frame.links) {
    const v = byId.get(l.sysid);
    if (!v) continue;
    const node = nodeFor(frame, l.sysid, l.tag);
    if (!node) { rings.set(l.sysid, worse(rings.get(l.sysid), l.state)); continue; }
    const key = `${l.sysid} ${node.name}`;
    const hop = hops.get(key);
    hops.set(key, [v, node, worse(hop ? hop[2] : undefined, l.state)]);
  }
  for (const [v, node, state] of hops.values()) {
    const [x0, y0] = xy(v.world_ned_m[0], v.world_ned_m[1]);
    const [x1, y1] = xy(node.world_ned_m[0], node.world_ned_m[1]);
    ctx.strokeStyle = colour(state); ctx.lineWidth = 2.5;
    ctx.setLineDash(state === "idle" ? [4, 4] : []);
    ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1); ctx.stroke();
  }
  ctx.setLineDash([]);
  // ground nodes
  for (const node of frame.nodes) {
    const [x, y] = xy(node.world_ned_m[0], node.world_ned_m[1]);
    ctx.fillStyle = "#20262e";
    ctx.beginPath(); ctx.moveTo(x, y - 9); ctx.lineTo(x + 8, y + 6); ctx.lineTo(x - 8, y + 6); ctx.closePath(); ctx.fill();
    ctx.font = "12px system-ui"; ctx.fillText(`${node.name} (${node.kind})`, x + 10, y + 4);
  }
  // vehicles; a label that would cover another one moves down, with a leader line
  const placed = [];
  for (const v of frame.vehicles) {
    const [x, y] = xy(v.world_ned_m[0], v.world_ned_m[1]);
    let ly = y;
    while (placed.some(([px, py]) => Math.abs(px - x) < 150 && Math.abs(py - ly) < 26)) ly += 26;
    placed.push([x, ly]);
    if (rings.has(v.sysid)) {
      ctx.strokeStyle = colour(rings.get(v.sysid)); ctx.lineWidth = 3;
      ctx.beginPath(); ctx.arc(x, y, 11, 0, 2 * Math.PI); ctx.stroke();
    }
    ctx.fillStyle = v.armed ? "#20262e" : "#fff"; ctx.strokeStyle = "#20262e"; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.arc(x, y, 6, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    const alt = v.rel_alt_m === null ? -v.world_ned_m[2] : v.rel_alt_m;
    if (ly !== y) {
      ctx.strokeStyle = "#aaa"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(x + 6, y); ctx.lineTo(x + 13, ly - 6); ctx.stroke();
    }
    ctx.fillStyle = "#111"; ctx.font = "bold 12px system-ui";
    ctx.fillText(`vehicle ${v.sysid}`, x + 14, ly - 2);
    ctx.font = "11px system-ui"; ctx.fillStyle = "#444";
    ctx.fillText(`${v.mode}${v.armed ? " · armed" : ""} · ${fmt(alt, 1)} m · ${fmt(100 * v.battery_remaining, 0)} %`, x + 14, ly + 11);
  }
  // scale bar and north
  const metres = niceLength(w / 5 / scale);
  const px = metres * scale;
  ctx.strokeStyle = "#222"; ctx.fillStyle = "#222"; ctx.lineWidth = 2;
  ctx.beginPath(); ctx.moveTo(16, h - 16); ctx.lineTo(16 + px, h - 16);
  ctx.moveTo(16, h - 21); ctx.lineTo(16, h - 11); ctx.moveTo(16 + px, h - 21); ctx.lineTo(16 + px, h - 11); ctx.stroke();
  ctx.font = "12px system-ui"; ctx.fillText(`${metres} m`, 20, h - 24);
  ctx.beginPath(); ctx.moveTo(w - 22, 14); ctx.lineTo(w - 28, 30); ctx.lineTo(w - 16, 30); ctx.closePath(); ctx.fill();
  ctx.fillText("N", w - 26, 44);
  drawTimeline(frame);
}

// --- the timeline --------------------------------------------------------------------------
const WINDOW_S = 120;

function drawTimeline(frame) {
  const [ctx, w, h] = sized($("timeline"));
  ctx.clearRect(0, 0, w, h);
  const bins = frame.timeline;
  const t1 = frame.t === null ? WINDOW_S : Math.max(frame.t, WINDOW_S);
  const t0 = t1 - WINDOW_S;
  $("timeline-note").textContent = `(last ${WINDOW_S} s of simulated time)`;
  const x = (t) => 30 + (t - t0) / WINDOW_S * (w - 40);
  const shown = bins.filter((b) => b.t >= t0);
  const total = (b) => Object.values(b.dropped).reduce((a, c) => a + c, 0) + b.late;
  const top = Math.max(1, ...shown.map(total));
  const y = (k) => h - 16 - k / top * (h - 30);
  const barW = Math.max(2, (w - 40) / WINDOW_S * 0.8);
  for (const b of shown) {
    let k = 0;
    for (const [reason, count] of Object.entries(b.dropped)) {
      ctx.fillStyle = REASON_COLOURS[reason] || "#555";
      ctx.fillRect(x(b.t) - barW, y(k + count), barW, y(k) - y(k + count));
      k += count;
    }
    if (b.late) { ctx.fillStyle = css("--late"); ctx.fillRect(x(b.t) - barW, y(k + b.late), barW, y(k) - y(k + b.late)); }
  }
  ctx.strokeStyle = "#bbb"; ctx.lineWidth = 1;
  ctx.beginPath(); ctx.moveTo(30, h - 16); ctx.lineTo(w - 10, h - 16); ctx.stroke();
  ctx.fillStyle = "#555"; ctx.font = "11px system-ui";
  for (let t = Math.ceil(t0 / 20) * 20; t <= t1; t += 20) ctx.fillText(`${t} s`, x(t) - 8, h - 3);
  ctx.fillText(String(top), 2, 12);
  ctx.strokeStyle = css("--late"); ctx.setLineDash([3, 3]);
  for (const ev of frame.events) {
    if (ev.kind !== "fault" || ev.t < t0) continue;
    ctx.beginPath(); ctx.moveTo(x(ev.t), 4); ctx.lineTo(x(ev.t), h - 16); ctx.stroke();
    ctx.fillText(ev.text, x(ev.t) + 3, 28);
  }
  ctx.setLineDash([]);
  let lx = 60;
  for (const [reason, c] of Object.entries(REASON_COLOURS)) {
    ctx.fillStyle = c; ctx.fillRect(lx, 4, 9, 9);
    const label = reason === "late" ? "late" : `dropped: ${reason}`;
    ctx.fillStyle = "#333"; ctx.fillText(label, lx + 12, 12);
    lx += ctx.measureText(label).width + 24;
  }
}

// Where the pointer is on the map: metres north/east of home, and latitude/longitude (a flat
// earth around home, as PX4's local frame).
$("map").addEventListener("mousemove", (ev) => {
  const frame = view.frame;
  if (!frame || !view.ne) return;
  const r = ev.target.getBoundingClientRect();
  const [n, e] = view.ne(ev.clientX - r.left, ev.clientY - r.top);
  let text = `pointer N ${fmt(n, 1)} m, E ${fmt(e, 1)} m`;
  if (frame.home) {
    const R = 6371000, lat0 = frame.home.lat_deg * Math.PI / 180;
    const lat = frame.home.lat_deg + n / R * 180 / Math.PI;
    const lon = frame.home.lon_deg + e / (R * Math.cos(lat0)) * 180 / Math.PI;
    text += ` · ${fmt(lat, 7)}, ${fmt(lon, 7)}`;
  }
  $("pointer").textContent = text;
});
$("map").addEventListener("mouseleave", () => { $("pointer").textContent = ""; });
window.addEventListener("resize", () => requestAnimationFrame(draw));
connect();
