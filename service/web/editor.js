// The domain editor: draw a polygon by clicks (outer ring, then holes), snap to a grid,
// undo; show a GeoJSON geometry; highlight the vertices and segments a 422 names.

const CLOSE_PX = 9;

export class DomainEditor {
  constructor(canvas, { onChange = () => {}, onStatus = () => {} } = {}) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.onChange = onChange;
    this.onStatus = onStatus;
    this.polygons = []; // [[ring, ...], ...], rings open (no repeated first point)
    this.current = []; // the ring being drawn
    this.snap = true;
    this.grid = 0.05;
    this.view = { x0: -0.25, y0: -0.25, x1: 1.25, y1: 1.25 };
    this.cursor = null;
    this.marks = { segments: [], vertices: [] };
    this.history = [];
    canvas.addEventListener("click", (e) => this._click(e));
    canvas.addEventListener("mousemove", (e) => { this.cursor = this._world(e); this.draw(); });
    canvas.addEventListener("mouseleave", () => { this.cursor = null; this.draw(); });
    canvas.addEventListener("wheel", (e) => this._wheel(e), { passive: false });
    canvas.addEventListener("keydown", (e) => this._key(e));
    new ResizeObserver(() => this._resize()).observe(canvas);
    this._resize();
  }

  // ------------------------------------------------------------------ model

  /** The drawn domain as a GeoJSON Polygon/MultiPolygon geometry, or null when empty. */
  geometry() {
    const polys = this.polygons.filter((p) => p.length);
    if (!polys.length) return null;
    const close = (ring) => [...ring.map((p) => [...p]), [...ring[0]]];
    if (polys.length === 1) return { type: "Polygon", coordinates: polys[0].map(close) };
    return { type: "MultiPolygon", coordinates: polys.map((p) => p.map(close)) };
  }

  setGeometry(geo, { fit = true } = {}) {
    this._remember();
    const polys = geo.type === "MultiPolygon" ? geo.coordinates : [geo.coordinates];
    this.polygons = polys.map((rings) =>
      rings.map((ring) => {
        const pts = ring.map((p) => [Number(p[0]), Number(p[1])]);
        const [a, b] = [pts[0], pts[pts.length - 1]];
        if (pts.length > 1 && a[0] === b[0] && a[1] === b[1]) pts.pop();
        return pts;
      }),
    );
    this.current = [];
    this.clearMarks();
    if (fit) this.fit();
    this._changed();
  }

  clear() {
    this._remember();
    this.polygons = [];
    this.current = [];
    this.clearMarks();
    this._changed();
  }

  ringCount() {
    return this.polygons.reduce((n, p) => n + p.length, 0);
  }

  addPoint(x, y) {
    if (!Number.isFinite(x) || !Number.isFinite(y)) return;
    const p = this.snap ? [this._snap(x), this._snap(y)] : [x, y];
    const last = this.current[this.current.length - 1];
    if (last && last[0] === p[0] && last[1] === p[1]) return; // a double click adds one point
    this._remember();
    this.current.push(p);
    this._changed();
  }

  /** Close the ring being drawn: the first ring is the outer one, later ones its holes. */
  closeRing() {
    if (this.current.length < 3) {
      this.onStatus("A ring needs at least 3 points.");
      return false;
    }
    this._remember();
    if (!this.polygons.length) this.polygons.push([]);
    this.polygons[this.polygons.length - 1].push(this.current);
    this.current = [];
    this._changed();
    return true;
  }

  undo() {
    const prev = this.history.pop();
    if (!prev) return;
    this.polygons = prev.polygons;
    this.current = prev.current;
    this.clearMarks();
    this.onChange(this);
    this.draw();
  }

  _remember() {
    this.history.push({ polygons: structuredClone(this.polygons), current: structuredClone(this.current) });
    if (this.history.length > 200) this.history.shift();
  }

  _changed() {
    this.marks = { segments: [], vertices: [] };
    this.onChange(this);
    this.draw();
  }

  prompt() {
    if (this.current.length) {
      return `Drawing ${this.ringCount() ? "a hole" : "the outer ring"}: ${this.current.length} points; ` +
        "click the first point or press Enter to close it.";
    }
    return this.ringCount()
      ? "Click to start a hole, or go on to the method."
      : "Click to place the outer ring's points (or pick an example, or paste GeoJSON).";
  }

  // ------------------------------------------------------------------ marks

  clearMarks() {
    this.marks = { segments: [], vertices: [] };
    this.draw();
  }

  /** Highlight segments [poly, ring, a, b] and vertices [poly, ring, v] (indices as sent). */
  mark({ segments = [], vertices = [] }) {
    this.marks = { segments, vertices };
    this.draw();
  }

  _ring(poly, ring) {
    return (this.polygons[poly] || [])[ring] || null;
  }

  // ------------------------------------------------------------------ view

  fit() {
    const pts = [...this.polygons.flat(2), ...this.current];
    if (!pts.length) {
      this.view = { x0: -0.25, y0: -0.25, x1: 1.25, y1: 1.25 };
    } else {
      let [x0, y0, x1, y1] = [Infinity, Infinity, -Infinity, -Infinity];
      for (const [x, y] of pts) {
        x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
      }
      const pad = 0.12 * Math.max(x1 - x0, y1 - y0, 1e-9);
      this.view = { x0: x0 - pad, y0: y0 - pad, x1: x1 + pad, y1: y1 + pad };
      const span = Math.max(x1 - x0, y1 - y0, 1e-9);
      this.grid = 10 ** Math.floor(Math.log10(span / 4)) / 2;
    }
    this.draw();
  }

  _resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(this.canvas.clientWidth * dpr));
    const h = Math.max(1, Math.round(this.canvas.clientHeight * dpr));
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
    }
    this.draw();
  }

  /** World -> CSS pixels (uniform scale, the view centred). */
  _transform() {
    const w = this.canvas.clientWidth || 1;
    const h = this.canvas.clientHeight || 1;
    const v = this.view;
    const s = Math.min(w / (v.x1 - v.x0), h / (v.y1 - v.y0));
    const cx = (v.x0 + v.x1) / 2;
    const cy = (v.y0 + v.y1) / 2;
    return { s, ox: w / 2 - s * cx, oy: h / 2 + s * cy };
  }

  toScreen(x, y) {
    const t = this._transform();
    return [t.ox + t.s * x, t.oy - t.s * y];
  }

  _world(e) {
    const r = this.canvas.getBoundingClientRect();
    const t = this._transform();
    return [(e.clientX - r.left - t.ox) / t.s, (t.oy - (e.clientY - r.top)) / t.s];
  }

  _snap(v) {
    return Math.round(Math.round(v / this.grid) * this.grid * 1e9) / 1e9;
  }

  _click(e) {
    this.canvas.focus();
    const [x, y] = this._world(e);
    if (this.current.length >= 3) {
      const [fx, fy] = this.toScreen(...this.current[0]);
      const r = this.canvas.getBoundingClientRect();
      if (Math.hypot(e.clientX - r.left - fx, e.clientY - r.top - fy) <= CLOSE_PX) {
        this.closeRing();
        return;
      }
    }
    this.addPoint(x, y);
  }

  _wheel(e) {
    e.preventDefault();
    const [x, y] = this._world(e);
    this.zoom(e.deltaY > 0 ? 1.15 : 1 / 1.15, x, y);
  }

  zoom(f, x, y) {
    const v = this.view;
    x ??= (v.x0 + v.x1) / 2;
    y ??= (v.y0 + v.y1) / 2;
    this.view = { x0: x + (v.x0 - x) * f, x1: x + (v.x1 - x) * f, y0: y + (v.y0 - y) * f, y1: y + (v.y1 - y) * f };
    this.draw();
  }

  pan(dx, dy) {
    const v = this.view;
    const sx = (v.x1 - v.x0) * dx;
    const sy = (v.y1 - v.y0) * dy;
    this.view = { x0: v.x0 + sx, x1: v.x1 + sx, y0: v.y0 + sy, y1: v.y1 + sy };
    this.draw();
  }

  _key(e) {
    const keys = {
      Enter: () => this.closeRing(),
      "+": () => this.zoom(1 / 1.2), "=": () => this.zoom(1 / 1.2), "-": () => this.zoom(1.2),
      ArrowLeft: () => this.pan(-0.1, 0), ArrowRight: () => this.pan(0.1, 0),
      ArrowUp: () => this.pan(0, 0.1), ArrowDown: () => this.pan(0, -0.1),
    };
    if ((e.ctrlKey || e.metaKey) && e.key === "z") {
      e.preventDefault();
      this.undo();
    } else if (keys[e.key]) {
      e.preventDefault();
      keys[e.key]();
    }
  }

  // ------------------------------------------------------------------ drawing

  draw() {
    const { ctx, canvas } = this;
    const dpr = canvas.width / (canvas.clientWidth || 1);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const w = canvas.clientWidth;
    const h = canvas.clientHeight;
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, w, h);
    const t = this._transform();
    const P = ([x, y]) => [t.ox + t.s * x, t.oy - t.s * y];
    // grid
    const step = this.grid * Math.max(1, 2 ** Math.ceil(Math.log2(8 / (this.grid * t.s))));
    ctx.lineWidth = 1;
    const [gx0, gy1] = [(-t.ox) / t.s, t.oy / t.s];
    const [gx1, gy0] = [(w - t.ox) / t.s, (t.oy - h) / t.s];
    ctx.strokeStyle = "#e6e9ef";
    ctx.beginPath();
    for (let x = Math.ceil(gx0 / step) * step; x <= gx1; x += step) {
      const [sx] = P([x, 0]);
      ctx.moveTo(sx, 0); ctx.lineTo(sx, h);
    }
    for (let y = Math.ceil(gy0 / step) * step; y <= gy1; y += step) {
      const [, sy] = P([0, y]);
      ctx.moveTo(0, sy); ctx.lineTo(w, sy);
    }
    ctx.stroke();
    ctx.strokeStyle = "#b8bfcc";
    ctx.beginPath();
    const [ax, ay] = P([0, 0]);
    ctx.moveTo(ax, 0); ctx.lineTo(ax, h); ctx.moveTo(0, ay); ctx.lineTo(w, ay);
    ctx.stroke();
    // polygons
    for (const rings of this.polygons) {
      ctx.beginPath();
      for (const ring of rings) {
        ring.forEach((p, i) => (i ? ctx.lineTo(...P(p)) : ctx.moveTo(...P(p))));
        ctx.closePath();
      }
      ctx.fillStyle = "rgba(40, 110, 200, 0.18)";
      ctx.fill("evenodd");
      ctx.strokeStyle = "#1d4f91";
      ctx.lineWidth = 2;
      ctx.stroke();
      for (const ring of rings) this._vertices(ring, P, "#1d4f91");
    }
    // ring being drawn
    if (this.current.length) {
      ctx.beginPath();
      this.current.forEach((p, i) => (i ? ctx.lineTo(...P(p)) : ctx.moveTo(...P(p))));
      if (this.cursor) {
        const c = this.snap ? this.cursor.map((v) => this._snap(v)) : this.cursor;
        ctx.lineTo(...P(c));
      }
      ctx.strokeStyle = "#c05600";
      ctx.lineWidth = 2;
      ctx.setLineDash([6, 4]);
      ctx.stroke();
      ctx.setLineDash([]);
      this._vertices(this.current, P, "#c05600");
      if (this.current.length >= 3) {
        ctx.beginPath();
        ctx.arc(...P(this.current[0]), CLOSE_PX, 0, 2 * Math.PI);
        ctx.strokeStyle = "#c05600";
        ctx.lineWidth = 1;
        ctx.stroke();
      }
    }
    // marks from a 422
    ctx.strokeStyle = "#d00000";
    ctx.fillStyle = "#d00000";
    ctx.lineWidth = 5;
    for (const [poly, ri, a, b] of this.marks.segments) {
      const ring = this._ring(poly, ri);
      if (!ring) continue;
      ctx.beginPath();
      ctx.moveTo(...P(ring[a % ring.length]));
      ctx.lineTo(...P(ring[b % ring.length]));
      ctx.stroke();
    }
    ctx.font = "bold 13px system-ui, sans-serif";
    for (const [poly, ri, v] of this.marks.vertices) {
      const ring = this._ring(poly, ri);
      if (!ring || !ring[v % ring.length]) continue;
      const [sx, sy] = P(ring[v % ring.length]);
      ctx.beginPath();
      ctx.lineWidth = 3;
      ctx.arc(sx, sy, 8, 0, 2 * Math.PI);
      ctx.stroke();
      ctx.fillText(`ring ${ri} vertex ${v}`, sx + 10, sy - 10);
    }
    // cursor coordinates
    if (this.cursor) {
      const c = this.snap ? this.cursor.map((v) => this._snap(v)) : this.cursor;
      ctx.fillStyle = "#333";
      ctx.font = "12px system-ui, sans-serif";
      ctx.fillText(`(${fmt(c[0])}, ${fmt(c[1])})`, 8, h - 8);
    }
  }

  _vertices(ring, P, color) {
    this.ctx.fillStyle = color;
    for (const p of ring) {
      const [x, y] = P(p);
      this.ctx.fillRect(x - 3, y - 3, 6, 6);
    }
  }
}

function fmt(v) {
  return Number(v.toPrecision(6)).toString();
}
