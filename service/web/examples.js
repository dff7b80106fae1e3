// Example domains (GeoJSON Polygon geometries) for the domain editor.

function circle(cx, cy, r, n, phase = 0) {
  return Array.from({ length: n }, (_, i) => {
    const t = phase + (2 * Math.PI * i) / n;
    return [round(cx + r * Math.cos(t)), round(cy + r * Math.sin(t))];
  });
}

function round(v) {
  return Math.round(v * 1e6) / 1e6;
}

function star(points, outer, inner) {
  return Array.from({ length: 2 * points }, (_, i) => {
    const r = i % 2 ? inner : outer;
    const t = Math.PI / 2 + (Math.PI * i) / points;
    return [round(0.5 + r * Math.cos(t)), round(0.5 + r * Math.sin(t))];
  });
}

function gear(teeth, outer, root) {
  const ring = [];
  for (let i = 0; i < teeth; i++) {
    const t0 = (2 * Math.PI * i) / teeth;
    const w = (2 * Math.PI) / teeth;
    for (const [f, r] of [[0, root], [0.2, outer], [0.5, outer], [0.7, root]]) {
      const t = t0 + f * w;
      ring.push([round(0.5 + r * Math.cos(t)), round(0.5 + r * Math.sin(t))]);
    }
  }
  return ring;
}

export const EXAMPLES = {
  "square with a hole": {
    type: "Polygon",
    coordinates: [
      [[0, 0], [1, 0], [1, 1], [0, 1]],
      [[0.3, 0.3], [0.3, 0.7], [0.7, 0.7], [0.7, 0.3]],
    ],
  },
  "L-shape": {
    type: "Polygon",
    coordinates: [[[0, 0], [1, 0], [1, 0.4], [0.4, 0.4], [0.4, 1], [0, 1]]],
  },
  star: { type: "Polygon", coordinates: [star(5, 0.5, 0.2)] },
  gear: { type: "Polygon", coordinates: [gear(12, 0.5, 0.4), circle(0.5, 0.5, 0.12, 16)] },
};
