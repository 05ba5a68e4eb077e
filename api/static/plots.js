// Minimal SVG plotting for the dashboard (no dependencies): axes with nice ticks, lines, markers, areas, legend.
// Colours are SVG presentation attributes (no style attribute: the Content-Security-Policy forbids inline styles).
"use strict";
window.svgplot = (function () {
  const NS = "http://www.w3.org/2000/svg";

  function el(parent, name, attrs, text) {
    const node = document.createElementNS(NS, name);
    for (const k in attrs || {}) node.setAttribute(k, attrs[k]);
    if (text !== undefined) node.textContent = text;
    parent.appendChild(node);
    return node;
  }

  function niceTicks(lo, hi, n) {
    if (!(hi > lo)) { hi = lo + 1; lo = lo - 1; }
    const raw = (hi - lo) / (n || 5);
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 2.5, 5, 10].map(function (m) { return m * mag; }).find(function (s) { return s >= raw; });
    const out = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) out.push(Number(v.toPrecision(12)));
    return out;
  }

  function fmt(v) {
    const a = Math.abs(v);
    return a !== 0 && (a >= 1e5 || a < 1e-3) ? v.toExponential(1) : String(Number(v.toPrecision(4)));
  }

  // frame(svg, {xmin, xmax, ymin, ymax, xlabel, ylabel, xticks}) -> {x(v), y(v), root, w, h}
  function frame(svg, o) {
    while (svg.firstChild) svg.removeChild(svg.firstChild);
    const vb = svg.viewBox.baseVal;
    const W = vb.width, H = vb.height, L = 64, Rm = 12, T = 24, B = 42;
    const pad = function (lo, hi) { const d = hi - lo || Math.abs(hi) || 1; return [lo - 0.04 * d, hi + 0.04 * d]; };
    const xs = o.exactX ? [o.xmin, o.xmax] : pad(o.xmin, o.xmax);
    const ys = pad(o.ymin, o.ymax);
    const x = function (v) { return L + (v - xs[0]) / (xs[1] - xs[0]) * (W - L - Rm); };
    const y = function (v) { return H - B - (v - ys[0]) / (ys[1] - ys[0]) * (H - T - B); };
    const root = el(svg, "g", { class: "frame" });
    el(root, "rect", { x: L, y: T, width: W - L - Rm, height: H - T - B, fill: "#fff", stroke: "#9aa5b1" });
    for (const t of o.xticks || niceTicks(xs[0], xs[1], 6)) {
      if (t < xs[0] || t > xs[1]) continue;
      el(root, "line", { x1: x(t), x2: x(t), y1: H - B, y2: H - B + 4, stroke: "#555" });
      el(root, "text", { x: x(t), y: H - B + 16, "text-anchor": "middle", "font-size": 11 }, fmt(t));
    }
    for (const t of niceTicks(ys[0], ys[1], 5)) {
      el(root, "line", { x1: L, x2: W - Rm, y1: y(t), y2: y(t), stroke: "#eef1f4" });
      el(root, "text", { x: L - 5, y: y(t) + 4, "text-anchor": "end", "font-size": 11 }, fmt(t));
    }
    el(root, "text", { x: (L + W - Rm) / 2, y: H - 6, "text-anchor": "middle", "font-size": 12 }, o.xlabel || "");
    el(root, "text", { x: 14, y: (T + H - B) / 2, "text-anchor": "middle", "font-size": 12,
                       transform: "rotate(-90 14 " + (T + H - B) / 2 + ")" }, o.ylabel || "");
    return { x: x, y: y, root: el(svg, "g", { class: "data" }), svg: svg, L: L, T: T, W: W, H: H, B: B, Rm: Rm };
  }

  function line(f, pts, attrs) {
    if (!pts.length) return null;
    const d = pts.map(function (p, i) { return (i ? "L" : "M") + f.x(p[0]).toFixed(1) + " " + f.y(p[1]).toFixed(1); });
    return el(f.root, "path", Object.assign({ d: d.join(" "), fill: "none", "stroke-width": 2 }, attrs));
  }

  function area(f, upper, lower, attrs) {
    const pts = upper.concat(lower.slice().reverse());
    const d = pts.map(function (p, i) { return (i ? "L" : "M") + f.x(p[0]).toFixed(1) + " " + f.y(p[1]).toFixed(1); });
    return el(f.root, "path", Object.assign({ d: d.join(" ") + " Z", stroke: "none" }, attrs));
  }

  function dots(f, pts, attrs, r) {
    const g = el(f.root, "g", attrs);
    for (const p of pts) el(g, "circle", { cx: f.x(p[0]).toFixed(1), cy: f.y(p[1]).toFixed(1), r: r || 3 });
    return g;
  }

  // one row of legend entries above the plot area (it never covers the data)
  function legend(f, items) {
    const g = el(f.svg, "g", { class: "legend" });
    let xx = f.L;
    for (const it of items) {
      const yy = 13;
      if (it.dot) el(g, "circle", { cx: xx + 6, cy: yy - 4, r: 4, fill: it.color });
      else el(g, "line", { x1: xx, x2: xx + 14, y1: yy - 4, y2: yy - 4, stroke: it.color, "stroke-width": 3,
                           "stroke-dasharray": it.dash || "none" });
      el(g, "text", { x: xx + 18, y: yy, "font-size": 11 }, it.label);
      xx += 30 + 6.2 * it.label.length;
    }
    return g;
  }

  function message(svg, text) {
    while (svg.firstChild) svg.removeChild(svg.firstChild);
    el(svg, "text", { x: 20, y: 40, "font-size": 13, fill: "#778", class: "empty" }, text);
  }

  return { el: el, frame: frame, line: line, area: area, dots: dots, legend: legend, message: message,
           niceTicks: niceTicks, fmt: fmt };
})();
