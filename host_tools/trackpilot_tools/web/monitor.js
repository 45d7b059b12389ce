// trackpilot web monitor: polls /api/state (twice a second) and draws the boats on the track in
// local east/north metres, their cross-track error and heading/command over the last minutes.
// Plain JavaScript, no libraries: it is shipped in the package and works offline on the water.
"use strict";

const COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b"];
const POLL_MS = 500;
let state = null;
let selected = null; // boat id whose leg and charts are shown
const view = { cx: 0, cy: 0, mpp: 1.0, fitted: false }; // centre (m) and metres per pixel

function colour(id) { return COLOURS[id % COLOURS.length]; }
function esc(s) { return String(s).replace(/[&<>"]/g, c => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;"}[c])); }
function fmt(v, nd, unit) { return v === null || v === undefined ? "-" : v.toFixed(nd) + (unit || ""); }

// ---- map: world (m, north up) <-> canvas pixels
function sizeCanvas(cv) {
  const r = cv.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(100, Math.round(r.width * dpr)), h = Math.max(80, Math.round(r.height * dpr));
  if (cv.width !== w || cv.height !== h) { cv.width = w; cv.height = h; }
  return dpr;
}
function toPx(cv, e, n) { return [cv.width / 2 + (e - view.cx) / view.mpp, cv.height / 2 - (n - view.cy) / view.mpp]; }
function toWorld(cv, x, y) { return [view.cx + (x - cv.width / 2) * view.mpp, view.cy - (y - cv.height / 2) * view.mpp]; }

function extent() {
  const pts = [];
  if (state) {
    for (const w of state.track) pts.push([w.e, w.n]);
    for (const b of state.boats) if (b.e !== null) pts.push([b.e, b.n]);
  }
  return pts;
}
function fit() {
  const cv = document.getElementById("map");
  const pts = extent();
  if (!pts.length) return false;
  let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
  for (const [e, n] of pts) { x0 = Math.min(x0, e); x1 = Math.max(x1, e); y0 = Math.min(y0, n); y1 = Math.max(y1, n); }
  view.cx = (x0 + x1) / 2; view.cy = (y0 + y1) / 2;
  view.mpp = Math.max((x1 - x0 + 40) / cv.width, (y1 - y0 + 40) / cv.height, 0.05);
  view.fitted = true;
  return true;
}
function zoom(f, px, py) {
  const cv = document.getElementById("map");
  const [e, n] = toWorld(cv, px === undefined ? cv.width / 2 : px, py === undefined ? cv.height / 2 : py);
  view.mpp = Math.min(Math.max(view.mpp * f, 0.01), 200);
  const [e2, n2] = toWorld(cv, px === undefined ? cv.width / 2 : px, py === undefined ? cv.height / 2 : py);
  view.cx += e - e2; view.cy += n - n2;
  drawMap();
}

function drawMap() {
  const cv = document.getElementById("map");
  const dpr = sizeCanvas(cv);
  const g = cv.getContext("2d");
  g.clearRect(0, 0, cv.width, cv.height);
  if (!state) return;
  if (!view.fitted) fit();
  const sel = state.boats.find(b => b.id === selected);
  if (document.getElementById("follow").checked && sel && sel.e !== null) { view.cx = sel.e; view.cy = sel.n; }
  g.font = (11 * dpr) + "px system-ui, sans-serif";
  // planned path
  const tr = state.track;
  if (tr.length) {
    g.strokeStyle = "#888"; g.lineWidth = 1.5 * dpr; g.setLineDash([6 * dpr, 4 * dpr]);
    g.beginPath();
    tr.forEach((w, i) => { const [x, y] = toPx(cv, w.e, w.n); if (i) g.lineTo(x, y); else g.moveTo(x, y); });
    g.stroke(); g.setLineDash([]);
    if (sel && sel.nav_valid && sel.leg + 1 < tr.length) { // the selected boat's current leg
      const a = toPx(cv, tr[sel.leg].e, tr[sel.leg].n), b = toPx(cv, tr[sel.leg + 1].e, tr[sel.leg + 1].n);
      g.strokeStyle = "#f4a261"; g.lineWidth = 5 * dpr;
      g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke();
    }
    g.fillStyle = "#555";
    let lastLabel = null;
    tr.forEach(w => {
      const [x, y] = toPx(cv, w.e, w.n);
      g.beginPath(); g.arc(x, y, 3 * dpr, 0, 2 * Math.PI); g.fill();
      if (!lastLabel || Math.hypot(x - lastLabel[0], y - lastLabel[1]) > 40 * dpr) { // no piled-up names
        g.fillText(w.name, x + 5 * dpr, y - 5 * dpr); lastLabel = [x, y];
      }
    });
  }
  // trails and boats
  let drawn = 0;
  for (const b of state.boats) {
    const c = colour(b.id);
    g.strokeStyle = c; g.lineWidth = 1.5 * dpr; g.globalAlpha = 0.6;
    g.beginPath();
    let pen = false;
    for (let i = 0; i < b.history.e.length; i++) {
      const e = b.history.e[i], n = b.history.n[i];
      if (e === null) { pen = false; continue; } // no position: a gap, not a line
      const [x, y] = toPx(cv, e, n);
      if (pen) g.lineTo(x, y); else g.moveTo(x, y);
      pen = true;
    }
    g.stroke(); g.globalAlpha = 1.0;
    if (b.e === null) continue;
    const [x, y] = toPx(cv, b.e, b.n);
    g.save(); g.translate(x, y);
    g.fillStyle = b.stale ? "#aaa" : c; g.strokeStyle = "#000"; g.lineWidth = 1;
    if (b.heading_valid) {
      g.rotate(b.heading_deg * Math.PI / 180);
      g.beginPath(); g.moveTo(0, -14 * dpr); g.lineTo(7 * dpr, 9 * dpr); g.lineTo(-7 * dpr, 9 * dpr); g.closePath();
    } else {
      g.beginPath(); g.arc(0, 0, 6 * dpr, 0, 2 * Math.PI);
    }
    g.fill(); g.stroke(); g.restore();
    g.fillStyle = "#000"; g.fillText("boat " + b.id, x + 10 * dpr, y + 12 * dpr);
    drawn++;
  }
  cv.dataset.boatsDrawn = drawn;
  const m100 = 100 / view.mpp / dpr;
  document.getElementById("scale").textContent = "100 m = " + m100.toFixed(0) + " px";
}

// ---- charts: the selected boat's last minutes
function drawChart(id, series, label, fixedRange) {
  const cv = document.getElementById(id);
  const dpr = sizeCanvas(cv);
  const g = cv.getContext("2d");
  g.clearRect(0, 0, cv.width, cv.height);
  g.font = (11 * dpr) + "px system-ui, sans-serif";
  const b = state && state.boats.find(x => x.id === selected);
  const L = 40 * dpr, R = 8 * dpr, T = 16 * dpr, B = 18 * dpr;
  g.fillStyle = "#000"; g.fillText(label + (b ? " — boat " + b.id : ""), L, 12 * dpr);
  if (!b) return;
  const t = b.history.t, span = state.history_s;
  let lo = Infinity, hi = -Infinity;
  for (const s of series) for (const v of b.history[s.key]) if (v !== null) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (fixedRange) { lo = Math.min(lo, fixedRange[0]); hi = Math.max(hi, fixedRange[1]); }
  if (!(hi > lo)) { lo = -1; hi = 1; }
  const X = v => L + (v + span) / span * (cv.width - L - R);
  const Y = v => T + (hi - v) / (hi - lo) * (cv.height - T - B);
  g.strokeStyle = "#ddd"; g.lineWidth = 1;
  for (let k = 0; k <= 4; k++) {
    const v = lo + (hi - lo) * k / 4;
    g.beginPath(); g.moveTo(L, Y(v)); g.lineTo(cv.width - R, Y(v)); g.stroke();
    g.fillStyle = "#555"; g.fillText(v.toFixed(1), 2, Y(v) + 4);
  }
  g.fillText("-" + Math.round(span / 60) + " min", L, cv.height - 4); g.fillText("now", cv.width - R - 24 * dpr, cv.height - 4);
  series.forEach((s, j) => {
    g.strokeStyle = s.colour; g.lineWidth = 1.5 * dpr;
    g.beginPath();
    let pen = false;
    for (let i = 0; i < t.length; i++) {
      const v = b.history[s.key][i];
      if (v === null || (i && t[i] - t[i - 1] > 5)) { pen = false; if (v === null) continue; } // gaps stay gaps
      if (s.wrap && pen && Math.abs(v - b.history[s.key][i - 1]) > 180) pen = false; // 359 -> 0
      if (pen) g.lineTo(X(t[i]), Y(v)); else g.moveTo(X(t[i]), Y(v));
      pen = true;
    }
    g.stroke();
    g.fillStyle = s.colour; g.fillText(s.name, cv.width - R - 170 * dpr + j * 85 * dpr, 12 * dpr);
  });
}

// ---- boat cards
function card(b) {
  const alarms = b.alarms.length
    ? b.alarms.map(a => '<span class="alarm' + (a.ack ? ' ack' : '') + '">' + esc(a.name) + (a.ack ? " (ack)" : " SOUNDING") + "</span>").join("")
    : "-";
  const rows = [
    ["link", b.stale ? '<span class="stale">STALE ' + b.age_s.toFixed(1) + " s</span>" : "ok (" + b.age_s.toFixed(1) + " s)"],
    ["alarms", alarms],
  ];
  if (b.alarm_reason) rows.push(["alarm", esc(b.alarm_reason)]);
  if (b.refusal) rows.push(["refused", esc(b.refusal)]);
  rows.push(
    ["fix", b.pos_valid ? b.lat.toFixed(7) + " " + b.lon.toFixed(7) : "no position"],
    ["RTK / sats", esc(b.rtk) + " / " + b.num_sv],
    ["heading / cmd", (b.heading_valid ? fmt(b.heading_deg, 1, "°") : "BAD") + " / " + (b.cmd_valid ? fmt(b.heading_cmd_deg, 1, "°") : "-")],
    ["xte", b.nav_valid ? fmt(b.xte_m, 2, " m") + (b.xte_m > 0 ? " stbd" : b.xte_m < 0 ? " port" : "") : "no track"],
    ["leg / to wp", b.nav_valid ? (b.leg + 1) + "/" + b.legs + ", " + fmt(b.to_wp_m, 0, " m") : "-"],
    ["speed", fmt(b.sog_mps, 2, " m/s")],
    ["rpm cmd / rpm", b.rpm_cmd + " / " + (b.rpm < 0 ? "-" : b.rpm)],
    ["pilot", (b.pilot_ok ? "ok, " : "LOST, ") + esc(b.pilot_mode)],
    ["battery", b.battery_v < 0 ? "-" : fmt(b.battery_v, 2, " V")],
    ["seq / lost", b.seq + " / " + b.lost],
  );
  return '<div class="boat' + (b.id === selected ? " selected" : "") + '" id="boat-' + b.id + '" data-id="' + b.id +
    '" data-seq="' + b.seq + '" data-e="' + b.e + '" data-n="' + b.n + '" data-mode="' + esc(b.mode_text) +
    '" data-stale="' + b.stale + '" style="--c:' + colour(b.id) + '">' +
    '<h3>boat ' + b.id + ' <span class="mode m' + b.mode + '">' + esc(b.mode_text) + "</span></h3><table>" +
    rows.map(r => "<tr><td>" + r[0] + "</td><td>" + r[1] + "</td></tr>").join("") + "</table></div>";
}

function render() {
  const box = document.getElementById("boats");
  if (state.boats.length) {
    if (selected === null || !state.boats.some(b => b.id === selected)) selected = state.boats[0].id;
    box.innerHTML = state.boats.map(card).join("");
  }
  const any = state.boats.length > 0, stale = any && state.boats.every(b => b.stale);
  const link = document.getElementById("link");
  link.textContent = !any ? "waiting for status" : stale ? "LINK STALE" : "link ok";
  link.className = "link" + (stale || !any ? " stale" : "");
  document.getElementById("source").textContent = state.source + ": " + state.datagrams + " datagrams" + (state.bad ? ", " + state.bad + " bad" : "");
  drawMap();
  drawChart("xte", [{key: "xte", name: "xte (m, + stbd)", colour: "#1f77b4"}], "cross-track error (m)", [-1.5, 1.5]);
  drawChart("hdg", [{key: "hdg", name: "heading", colour: "#2ca02c", wrap: true}, {key: "cmd", name: "command", colour: "#d62728", wrap: true}], "heading and command (° true)");
}

async function poll() {
  try {
    const r = await fetch("/api/state", {cache: "no-store"});
    state = await r.json();
    render();
  } catch (err) {
    const link = document.getElementById("link");
    link.textContent = "monitor server not answering"; link.className = "link stale";
  }
  setTimeout(poll, POLL_MS);
}

// ---- interaction: wheel zoom at the cursor, drag to pan, click a card to select a boat
(function () {
  const cv = document.getElementById("map");
  let drag = null;
  cv.addEventListener("wheel", ev => {
    ev.preventDefault();
    const r = cv.getBoundingClientRect(), k = cv.width / r.width;
    zoom(ev.deltaY > 0 ? 1.25 : 0.8, (ev.clientX - r.left) * k, (ev.clientY - r.top) * k);
  }, {passive: false});
  cv.addEventListener("pointerdown", ev => { drag = [ev.clientX, ev.clientY]; cv.setPointerCapture(ev.pointerId); });
  cv.addEventListener("pointermove", ev => {
    if (!drag) return;
    const r = cv.getBoundingClientRect(), k = cv.width / r.width;
    view.cx -= (ev.clientX - drag[0]) * k * view.mpp; view.cy += (ev.clientY - drag[1]) * k * view.mpp;
    drag = [ev.clientX, ev.clientY];
    drawMap();
  });
  cv.addEventListener("pointerup", () => { drag = null; });
  document.getElementById("zoomin").onclick = () => zoom(0.5);
  document.getElementById("zoomout").onclick = () => zoom(2);
  document.getElementById("fit").onclick = () => { fit(); drawMap(); };
  document.getElementById("boats").addEventListener("click", ev => {
    const c = ev.target.closest(".boat");
    if (c) { selected = Number(c.dataset.id); render(); }
  });
  window.addEventListener("resize", () => state && render());
})();
poll();
