// The quality histogram per cell type (SVG bars over [0, 1]) and the colour legend.

import { color, gradientCss } from "./colors.js";

const NS = "http://www.w3.org/2000/svg";

function svg(tag, attrs = {}, text) {
  const n = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) n.setAttribute(k, v);
  if (text !== undefined) n.textContent = text;
  return n;
}

/** An SVG histogram of `counts` (equal bins over [0, 1]) titled by cell type. */
export function histogram(cellType, entry) {
  const counts = entry.quality?.histogram || [];
  const W = 320, H = 150, L = 44, B = 28, T = 22;
  const max = Math.max(1, ...counts);
  const bw = (W - L - 8) / Math.max(counts.length, 1);
  const root = svg("svg", {
    viewBox: `0 0 ${W} ${H}`, class: "histogram", role: "img",
    "aria-label": `${cellType} quality histogram, ${counts.length} bins over 0 to 1: ${counts.join(", ")}`,
  });
  root.append(svg("text", { x: L, y: 14, class: "title" }, `${cellType}: ${entry.count} cells, mean ${fmt(entry.quality?.mean)}`));
  counts.forEach((c, i) => {
    const h = ((H - B - T) * c) / max;
    const bar = svg("rect", { x: L + i * bw + 1, y: H - B - h, width: bw - 2, height: h, fill: color((i + 0.5) / counts.length) });
    bar.append(svg("title", {}, `${(i / counts.length).toFixed(1)}-${((i + 1) / counts.length).toFixed(1)}: ${c}`));
    root.append(bar);
  });
  root.append(svg("line", { x1: L, y1: H - B, x2: W - 8, y2: H - B, class: "axis" }));
  root.append(svg("line", { x1: L, y1: T, x2: L, y2: H - B, class: "axis" }));
  for (const [v, anchor] of [[0, "start"], [0.5, "middle"], [1, "end"]]) {
    root.append(svg("text", { x: L + v * (W - L - 8), y: H - 10, "text-anchor": anchor }, String(v)));
  }
  root.append(svg("text", { x: L - 4, y: T + 4, "text-anchor": "end" }, String(max)));
  root.append(svg("text", { x: L - 4, y: H - B, "text-anchor": "end" }, "0"));
  root.append(svg("text", { x: (W + L) / 2, y: H - 0.5, "text-anchor": "middle", class: "label" }, "quality"));
  return root;
}

export function legend(label, lo, hi) {
  const box = document.createElement("div");
  box.className = "legend";
  const bar = document.createElement("span");
  bar.className = "legend-bar";
  bar.style.background = gradientCss();
  const a = document.createElement("span");
  a.textContent = lo;
  const b = document.createElement("span");
  b.textContent = hi;
  const t = document.createElement("span");
  t.className = "legend-label";
  t.textContent = label;
  box.append(t, a, bar, b);
  return box;
}

export function fmt(v) {
  if (v === null || v === undefined) return "–";
  if (typeof v === "number") return Number.isInteger(v) ? String(v) : Number(v.toPrecision(4)).toString();
  return String(v);
}
