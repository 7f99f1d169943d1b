"use strict";
// lash report: every figure drawn on a canvas from the data embedded above (no network, no
// library). Colours: one per run (full, reduced, ideal), the mechanism in brown.
const DATA = JSON.parse(document.getElementById("data").textContent);
const RUN_COLORS = { full: "#1f77b4", reduced: "#d62728", ideal: "#2ca02c" };
const OTHER_COLORS = ["#1f77b4", "#ff7f0e", "#9467bd"];
const BODY_COLOR = "#8c564b";
const colorOf = (label, k) => RUN_COLORS[label] || OTHER_COLORS[k % OTHER_COLORS.length];
const fmt = (v) => {
  const a = Math.abs(v);
  if (v === 0) return "0";
  if (a >= 1e4 && a < 1e7) return v.toFixed(0);
  return a >= 1e7 || a < 1e-3 ? v.toExponential(2) : +v.toPrecision(4) + "";
};

function ticks(lo, hi, count) {
  const span = hi - lo;
  if (!(span > 0)) return [lo];
  const raw = span / count, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => span / s <= count) || 10 * mag;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) out.push(Math.abs(v) < 1e-12 * span ? 0 : v);
  return out;
}

// A line plot with axes, zoom (drag across x; double-click resets) and optional log y.
class Plot {
  constructor(canvas, opts) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.opts = opts;
    this.series = [];
    this.zoom = null;
    this.pad = { l: 78, r: 16, t: 24, b: 40 };
    canvas.addEventListener("mousedown", (e) => (this.dragFrom = e.offsetX));
    canvas.addEventListener("mousemove", (e) => {
      if (this.dragFrom === undefined) return;
      this.draw();
      const c = this.ctx;
      c.fillStyle = "rgba(0,0,0,0.08)";
      c.fillRect(Math.min(this.dragFrom, e.offsetX), this.pad.t, Math.abs(e.offsetX - this.dragFrom), this.h());
    });
    canvas.addEventListener("mouseup", (e) => {
      const from = this.dragFrom;
      this.dragFrom = undefined;
      if (from !== undefined && Math.abs(e.offsetX - from) > 4) {
        const [a, b] = [from, e.offsetX].map((px) => this.xOf(px)).sort((p, q) => p - q);
        this.zoom = [a, b];
      }
      this.draw();
    });
    canvas.addEventListener("dblclick", () => {
      this.zoom = null;
      this.draw();
    });
  }
  w() { return this.canvas.width - this.pad.l - this.pad.r; }
  h() { return this.canvas.height - this.pad.t - this.pad.b; }
  xOf(px) { return this.x0 + ((px - this.pad.l) / this.w()) * (this.x1 - this.x0); }
  set(series) {
    this.series = series;
    this.zoom = null;
    this.draw();
  }
  ranges() {
    const log = this.opts.logY;
    let [x0, x1, y0, y1] = [Infinity, -Infinity, Infinity, -Infinity];
    for (const s of this.series) for (let i = 0; i < s.x.length; i++) { const x = s.x[i]; if (isFinite(x)) { x0 = Math.min(x0, x); x1 = Math.max(x1, x); } }
    if (this.opts.xRange) [x0, x1] = this.opts.xRange;
    if (this.zoom) [x0, x1] = this.zoom;
    for (const s of this.series)
      for (let i = 0; i < s.x.length; i++) {
        let y = s.y[i];
        if (s.x[i] < x0 || s.x[i] > x1 || !isFinite(y) || (log && y <= 0)) continue;
        if (log) y = Math.log10(y);
        y0 = Math.min(y0, y);
        y1 = Math.max(y1, y);
      }
    if (log && y0 < y1 - 8) y0 = y1 - 8; // eight decades below the largest amplitude
    if (!(y1 > y0)) { const m = isFinite(y0) ? y0 : 0; [y0, y1] = [m - 1, m + 1]; }
    const margin = 0.05 * (y1 - y0);
    return [x0, x1, y0 - margin, y1 + margin];
  }
  draw() {
    const c = this.ctx, p = this.pad, W = this.w(), H = this.h(), log = this.opts.logY;
    [this.x0, this.x1, this.y0, this.y1] = this.ranges();
    const X = (x) => p.l + ((x - this.x0) / (this.x1 - this.x0)) * W;
    const Y = (y) => p.t + H - ((y - this.y0) / (this.y1 - this.y0)) * H;
    c.clearRect(0, 0, this.canvas.width, this.canvas.height);
    c.font = "12px system-ui, sans-serif";
    c.strokeStyle = "#e8e8e8";
    c.fillStyle = "#444";
    c.lineWidth = 1;
    for (const x of ticks(this.x0, this.x1, 8)) {
      c.beginPath(); c.moveTo(X(x), p.t); c.lineTo(X(x), p.t + H); c.stroke();
      c.textAlign = "center"; c.fillText(fmt(x), X(x), p.t + H + 15);
    }
    const yTicks = log ? ticks(Math.ceil(this.y0), Math.floor(this.y1), 8).filter((v) => Number.isInteger(v)) : ticks(this.y0, this.y1, 6);
    for (const y of yTicks) {
      c.beginPath(); c.moveTo(p.l, Y(y)); c.lineTo(p.l + W, Y(y)); c.stroke();
      c.textAlign = "right"; c.fillText(log ? "1e" + y : fmt(y), p.l - 6, Y(y) + 4);
    }
    c.strokeStyle = "#999";
    c.strokeRect(p.l, p.t, W, H);
    c.textAlign = "center";
    c.fillText(this.opts.xLabel, p.l + W / 2, this.canvas.height - 6);
    c.save(); c.translate(14, p.t + H / 2); c.rotate(-Math.PI / 2); c.fillText(this.opts.yLabel(), 0, 0); c.restore();
    c.save();
    c.beginPath(); c.rect(p.l, p.t, W, H); c.clip();
    for (const s of this.series) {
      c.strokeStyle = s.color;
      c.lineWidth = 1.3;
      c.beginPath();
      let pen = false, last = -Infinity;
      for (let i = 0; i < s.x.length; i++) {
        let y = s.y[i];
        if (log) y = y > 0 ? Math.log10(y) : NaN;
        const x = s.x[i];
        if (!isFinite(y) || !isFinite(x)) { pen = false; continue; }
        if (this.opts.wraps && x < last) pen = false; // a new crank revolution
        if (pen) c.lineTo(X(x), Y(y)); else c.moveTo(X(x), Y(y));
        pen = true;
        last = x;
      }
      c.stroke();
    }
    c.restore();
    let lx = p.l + 8;
    for (const s of this.series) {
      c.fillStyle = s.color; c.fillRect(lx, p.t - 14, 14, 3);
      c.fillStyle = "#444"; c.textAlign = "left"; c.fillText(s.label, lx + 18, p.t - 9);
      lx += 28 + c.measureText(s.label).width;
    }
  }
}

function summaryTable() {
  const table = document.getElementById("summary");
  const joints = DATA.orbits.map((o) => o.joint);
  let head = "<tr><th>run</th><th>samples</th><th>steps</th><th>wall time [s]</th>";
  for (const j of joints) head += `<th>${j}: impacts</th><th>${j}: max |e| / c</th>`;
  table.innerHTML = head + "</tr>";
  DATA.runs.forEach((r, k) => {
    const s = r.summary;
    let row = `<tr><td><span class="swatch" style="background:${colorOf(r.label, k)}"></span>${r.label}</td>`;
    row += `<td>${s.samples ?? ""}</td><td>${s.steps ?? ""}</td><td>${s.wall_time_s != null ? fmt(s.wall_time_s) : ""}</td>`;
    for (const o of DATA.orbits) {
      const c = (s.clearances || []).find((x) => x.name === o.joint);
      row += c ? `<td>${c.impacts ?? ""}</td><td>${fmt(c.max_eccentricity / o.clearance)}</td>` : "<td></td><td></td>";
    }
    table.innerHTML += row + "</tr>";
  });
  if (DATA.speedup && typeof DATA.speedup === "object") {
    const parts = Object.entries(DATA.speedup).map(([k, v]) => `${k.replaceAll("_", " ")}: ${fmt(v)}×`);
    document.getElementById("speedup").textContent = "Speed-up of the reduced model — " + parts.join("; ");
  }
  document.getElementById("notes").innerHTML = DATA.notes.map((n) => `<li>${n}</li>`).join("");
}

function mechanism() {
  const a = DATA.animation, canvas = document.getElementById("mechanism");
  if (!a) { canvas.style.display = "none"; document.getElementById("mechanism-controls").style.display = "none"; return; }
  const c = canvas.getContext("2d"), slider = document.getElementById("frame"), label = document.getElementById("frame-time");
  const [xmin, xmax, ymin, ymax] = a.extent;
  const size = Math.max(xmax - xmin, ymax - ymin, 1e-9);
  const scale = Math.min((canvas.width - 120) / Math.max(xmax - xmin, 1e-3 * size), (canvas.height - 80) / Math.max(ymax - ymin, 1e-3 * size));
  const cx = (xmin + xmax) / 2, cy = (ymin + ymax) / 2;
  const X = (x) => canvas.width / 2 + (x - cx) * scale, Y = (y) => canvas.height / 2 - (y - cy) * scale;
  slider.max = a.times.length - 1;
  function draw(f) {
    c.clearRect(0, 0, canvas.width, canvas.height);
    c.font = "12px system-ui, sans-serif";
    c.fillStyle = "#666";
    c.fillText(`${a.axes[0]} →, ${a.axes[1]} ↑ (${fmt(size)} m across)`, 8, 16);
    c.fillStyle = "#999";
    for (const [gx, gy] of a.anchors) {
      c.beginPath(); c.moveTo(X(gx), Y(gy)); c.lineTo(X(gx) - 9, Y(gy) + 14); c.lineTo(X(gx) + 9, Y(gy) + 14); c.closePath(); c.fill();
    }
    a.frames[f].forEach((pts, b) => {
      c.strokeStyle = BODY_COLOR; c.fillStyle = BODY_COLOR; c.lineWidth = 7; c.lineJoin = "round"; c.lineCap = "round";
      if (a.bodies[b].block || pts.length < 4) {
        const s = 0.03 * size * scale;
        c.fillRect(X(pts[0]) - s, Y(pts[1]) - s / 2, 2 * s, s);
        return;
      }
      c.beginPath();
      for (let i = 0; i < pts.length; i += 2) (i ? c.lineTo : c.moveTo).call(c, X(pts[i]), Y(pts[i + 1]));
      if (pts.length > 4) c.closePath();
      c.stroke();
    });
    for (const j of a.joints) {
      const pts = a.frames[f][j.body];
      c.beginPath(); c.arc(X(pts[2 * j.point]), Y(pts[2 * j.point + 1]), j.clearance ? 7 : 5, 0, 2 * Math.PI);
      c.fillStyle = "#fff"; c.fill(); c.lineWidth = j.clearance ? 3 : 2; c.strokeStyle = j.clearance ? "#d62728" : "#333"; c.stroke();
    }
    label.textContent = `t = ${a.times[f].toFixed(5)} s`;
  }
  let frame = 0, timer = null;
  slider.addEventListener("input", () => draw((frame = +slider.value)));
  document.getElementById("play").addEventListener("click", (e) => {
    if (timer) { clearInterval(timer); timer = null; e.target.textContent = "Play"; return; }
    e.target.textContent = "Pause";
    timer = setInterval(() => { frame = (frame + 1) % a.times.length; slider.value = frame; draw(frame); }, 40);
  });
  draw(0);
}

function orbits() {
  const box = document.getElementById("orbits");
  for (const o of DATA.orbits) {
    const canvas = document.createElement("canvas");
    canvas.width = 340; canvas.height = 360;
    box.appendChild(canvas);
    // The circle at 1/1.25 of the half width, or less when the journal went further (penetration).
    let reach = o.clearance;
    for (const [, xs, ys] of o.runs) for (let i = 0; i < xs.length; i++) reach = Math.max(reach, Math.hypot(xs[i], ys[i]));
    const c = canvas.getContext("2d"), um = 1e6, R = Math.max(1.25 * o.clearance, 1.05 * reach) * um;
    const S = 150 / R, X = (x) => 170 + x * um * S, Y = (y) => 190 - y * um * S;
    c.font = "12px system-ui, sans-serif"; c.fillStyle = "#444"; c.textAlign = "center";
    c.fillText(`${o.joint}: ${o.axes[0]} →, ${o.axes[1]} ↑ [µm], clearance c = ${fmt(o.clearance * um)} µm`, 170, 16);
    c.strokeStyle = "#ddd"; c.lineWidth = 1;
    c.beginPath(); c.moveTo(X(-R / um), Y(0)); c.lineTo(X(R / um), Y(0)); c.moveTo(X(0), Y(-R / um)); c.lineTo(X(0), Y(R / um)); c.stroke();
    c.strokeStyle = "#222"; c.lineWidth = 1.5; c.setLineDash([5, 4]);
    c.beginPath(); c.arc(X(0), Y(0), o.clearance * um * S, 0, 2 * Math.PI); c.stroke(); c.setLineDash([]);
    o.runs.forEach(([label, xs, ys]) => {
      c.strokeStyle = colorOf(label, DATA.runs.findIndex((r) => r.label === label)); c.lineWidth = 1;
      c.beginPath();
      for (let i = 0; i < xs.length; i++) (i ? c.lineTo : c.moveTo).call(c, X(xs[i]), Y(ys[i]));
      c.stroke();
    });
  }
  if (!DATA.orbits.length) box.textContent = "No clearance joint in this scenario.";
}

// The crank angle [°, 0–360) at time t by linear interpolation in a run's table.
function crankAt(run, t) {
  const T = run.crank_t, A = run.crank_deg;
  let lo = 0, hi = T.length - 1;
  if (t <= T[0]) return A[0];
  if (t >= T[hi]) return A[hi];
  while (hi - lo > 1) { const m = (lo + hi) >> 1; if (T[m] <= t) lo = m; else hi = m; }
  const deg = A[lo] + ((A[hi] - A[lo]) * (t - T[lo])) / (T[hi] - T[lo]);
  return ((deg % 360) + 360) % 360;
}

function channels() {
  const select = document.getElementById("channel");
  for (const [name, unit] of DATA.channels) select.add(new Option(`${name} [${unit}]`, name));
  select.value = DATA.first_channel;
  const unit = () => (DATA.channels.find(([n]) => n === select.value) || ["", ""])[1];
  const overTime = new Plot(document.getElementById("over-time"), { xLabel: "time [s]", yLabel: () => `${select.value} [${unit()}]` });
  const overAngle = new Plot(document.getElementById("over-angle"), { xLabel: "crank angle [°]", yLabel: () => `${select.value} [${unit()}]`, xRange: [0, 360], wraps: true });
  const spectrum = new Plot(document.getElementById("spectrum"), { xLabel: "frequency [Hz]", yLabel: () => `amplitude of ${select.value} [${unit()}]`, logY: true });
  const hasCrank = DATA.runs.some((r) => r.crank_t.length > 1);
  if (!hasCrank) document.getElementById("over-angle").style.display = "none";
  function show() {
    const time = [], angle = [], spec = [];
    DATA.runs.forEach((r, k) => {
      const ch = r.channels[select.value];
      if (!ch) return;
      const color = colorOf(r.label, k), t = ch.t || r.time;
      time.push({ label: r.label, color, x: t, y: ch.y });
      if (r.crank_t.length > 1) angle.push({ label: r.label, color, x: Array.from(t, (v) => crankAt(r, v)), y: ch.y });
      spec.push({ label: r.label, color, x: ch.f, y: ch.a });
    });
    overTime.set(time);
    if (hasCrank) overAngle.set(angle);
    spectrum.set(spec);
  }
  select.addEventListener("change", show);
  show();
}

summaryTable();
mechanism();
orbits();
channels();
document.body.dataset.drawn = "yes";
