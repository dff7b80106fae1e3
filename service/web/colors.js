// The quality colour map (viridis, 0 = poor, 1 = ideal), shared by the shaders' stops,
// the legend and the histogram bars.

export const STOPS = [
  [0.267, 0.005, 0.329],
  [0.229, 0.322, 0.546],
  [0.128, 0.567, 0.551],
  [0.369, 0.789, 0.383],
  [0.993, 0.906, 0.144],
];

export function color(t) {
  const x = Math.min(Math.max(t, 0), 1) * (STOPS.length - 1);
  const i = Math.min(Math.floor(x), STOPS.length - 2);
  const f = x - i;
  const c = STOPS[i].map((a, k) => a + (STOPS[i + 1][k] - a) * f);
  return `rgb(${c.map((v) => Math.round(v * 255)).join(",")})`;
}

export function gradientCss() {
  return `linear-gradient(to right, ${STOPS.map((_, i) => color(i / (STOPS.length - 1))).join(", ")})`;
}
