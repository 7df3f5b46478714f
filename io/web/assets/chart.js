// hvac-twin dashboard: small SVG time charts (no library). A chart is a <figure> with a caption
// (name, latest value) and an SVG: per series a line and its ±2σ band, horizontal reference lines
// (thresholds, nameplate), a time axis in local time. Gaps in the data break the line.
"use strict";

const HvacChart = (() => {
  const SVG = "http://www.w3.org/2000/svg";
  const W = 360, H = 150, L = 50, R = 8, T = 8, B = 20;

  function el(name, attrs, parent) {
    const e = document.createElementNS(SVG, name);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, String(v));
    if (parent) parent.appendChild(e);
    return e;
  }

  // Tick values at 1, 2 or 5 x 10^k covering [lo, hi] with about `n` steps.
  function niceTicks(lo, hi, n) {
    const span = hi - lo;
    const raw = span / Math.max(n, 1);
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= raw) || 10 * mag;
    const ticks = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) ticks.push(v);
    return { ticks, step };
  }

  // A number with the decimals its step (or sigma) calls for.
  function fmt(v, step) {
    if (!isFinite(v)) return "–";
    if (!step) return v.toFixed(2);
    return v.toFixed(Math.max(0, Math.min(6, -Math.floor(Math.log10(step) + 1e-9))));
  }

  function clock(ms, withSeconds) {
    const d = new Date(ms);
    const p = (x) => String(x).padStart(2, "0");
    return p(d.getHours()) + ":" + p(d.getMinutes()) + (withSeconds ? ":" + p(d.getSeconds()) : "");
  }

  const TIME_STEPS = [10e3, 30e3, 60e3, 120e3, 300e3, 600e3, 900e3, 1800e3, 3600e3, 7200e3,
                      10800e3, 21600e3, 43200e3];

  // Splits points where no data came for a while: a gap more than 3 times both its neighbouring
  // gaps (and over 1.5 s). Minute buckets followed by every sample keep their line; a pause of the
  // samples, or an hour without buckets, breaks it.
  function segments(points) {
    if (points.length < 2) return [points];
    const gaps = [];
    for (let i = 1; i < points.length; i++) gaps.push(points[i].t - points[i - 1].t);
    const out = [[points[0]]];
    for (let i = 1; i < points.length; i++) {
      const g = gaps[i - 1];
      const around = Math.max(i >= 2 ? gaps[i - 2] : 0, i < gaps.length ? gaps[i] : 0);
      if (g > Math.max(3 * around, 1500) && around > 0) out.push([]);
      out[out.length - 1].push(points[i]);
    }
    return out;
  }

  function create(parent, title) {
    const figure = document.createElement("figure");
    figure.className = "chart";
    const caption = document.createElement("figcaption");
    const name = document.createElement("span");
    name.className = "name";
    name.textContent = title;
    const latest = document.createElement("span");
    latest.className = "latest";
    caption.append(name, latest);
    const svg = el("svg", { viewBox: `0 0 ${W} ${H}`, role: "img" });
    const legend = document.createElement("div");
    legend.className = "legend";
    figure.append(caption, svg, legend);
    parent.appendChild(figure);
    return { figure, svg, latest, legend, title };
  }

  // spec: { from, to (ms), series: [{label, points: [{t, v, s, lo, hi}], color, band: "value" |
  // "zero" | "none", dash}], refs: [{y, label, color, below}], latest: text, legend: text,
  // describe: text (the SVG's accessible name) }
  function draw(chart, spec) {
    const svg = chart.svg;
    while (svg.firstChild) svg.removeChild(svg.firstChild);
    const from = spec.from, to = spec.to;
    const x = (t) => L + ((t - from) / Math.max(to - from, 1)) * (W - L - R);
    let lo = Infinity, hi = -Infinity, count = 0;
    const visible = spec.series.map((s) => s.points.filter((p) => p.t >= from && p.t <= to));
    spec.series.forEach((s, i) => {
      for (const p of visible[i]) {
        count++;
        const plo = s.band === "zero" ? -2 * p.s : s.band === "value" ? p.lo : p.v;
        const phi = s.band === "zero" ? 2 * p.s : s.band === "value" ? p.hi : p.v;
        lo = Math.min(lo, plo, p.v);
        hi = Math.max(hi, phi, p.v);
      }
    });
    for (const r of spec.refs || []) {
      if (count === 0 || !isFinite(r.y)) continue;
      lo = Math.min(lo, r.y);
      hi = Math.max(hi, r.y);
    }
    chart.latest.textContent = spec.latest || "";
    chart.legend.textContent = spec.legend || "";
    svg.setAttribute("aria-label", `${chart.title}: ${spec.describe || spec.latest || "no data"}`);
    el("rect", { x: L, y: T, width: W - L - R, height: H - T - B, fill: "#fbfcfd", stroke: "#d0d7de" }, svg);
    if (count === 0) {
      const t = el("text", { x: (W + L) / 2, y: H / 2, "text-anchor": "middle", class: "empty" }, svg);
      t.textContent = "no data in this window";
      return;
    }
    if (hi - lo < 1e-12 * Math.max(1, Math.abs(hi))) {
      const pad = Math.abs(hi) > 0 ? Math.abs(hi) * 0.01 : 1;
      lo -= pad;
      hi += pad;
    }
    const pad = (hi - lo) * 0.06;
    lo -= pad;
    hi += pad;
    const y = (v) => T + (1 - (v - lo) / (hi - lo)) * (H - T - B);

    const { ticks, step } = niceTicks(lo, hi, 4);
    for (const v of ticks) {
      el("line", { x1: L, x2: W - R, y1: y(v), y2: y(v), stroke: "#e3e8ed" }, svg);
      const t = el("text", { x: L - 4, y: y(v) + 3, "text-anchor": "end" }, svg);
      t.textContent = fmt(v, step);
    }
    const span = to - from;
    const tstep = TIME_STEPS.find((s) => span / s <= 5) || 86400e3;
    for (let t = Math.ceil(from / tstep) * tstep; t <= to; t += tstep) {
      el("line", { x1: x(t), x2: x(t), y1: T, y2: H - B, stroke: "#eef1f4" }, svg);
      // A label that would stick out of the plot's ends is left out (its grid line stays).
      const half = tstep < 60e3 ? 20 : 14;
      if (x(t) - half < L - 8 || x(t) + half > W) continue;
      const label = el("text", { x: x(t), y: H - 6, "text-anchor": "middle" }, svg);
      label.textContent = clock(t, tstep < 60e3);
    }
    spec.series.forEach((s, i) => {
      for (const seg of segments(visible[i])) {
        if (seg.length === 0) continue;
        if (s.band && s.band !== "none") {
          const upper = seg.map((p) => `${x(p.t).toFixed(1)},${y(s.band === "zero" ? 2 * p.s : p.hi).toFixed(1)}`);
          const lower = seg.map((p) => `${x(p.t).toFixed(1)},${y(s.band === "zero" ? -2 * p.s : p.lo).toFixed(1)}`).reverse();
          el("polygon", { points: upper.concat(lower).join(" "), fill: s.color, "fill-opacity": 0.16 }, svg);
        }
        const d = seg.map((p, k) => `${k ? "L" : "M"}${x(p.t).toFixed(1)},${y(p.v).toFixed(1)}`).join("");
        const attrs = { d: seg.length === 1 ? d + "h1" : d, fill: "none", stroke: s.color, "stroke-width": 1.6 };
        if (s.dash) attrs["stroke-dasharray"] = s.dash;
        el("path", attrs, svg);
      }
    });
    for (const r of spec.refs || []) {
      if (!isFinite(r.y) || r.y < lo || r.y > hi) continue;
      el("line", { x1: L, x2: W - R, y1: y(r.y), y2: y(r.y), stroke: r.color, "stroke-width": 1.2,
                   "stroke-dasharray": "5 3" }, svg);
      const t = el("text", { x: W - R - 3, y: y(r.y) + (r.below ? 10 : -3), "text-anchor": "end" }, svg);
      t.textContent = r.label;
      t.setAttribute("fill", r.color);
    }
  }

  return { create, draw, fmt, clock };
})();
