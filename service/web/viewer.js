// The WebGL2 result view. 2D: orthographic, pan (drag, arrows) and zoom (wheel, +/-).
// 3D: orbit (drag, arrows), zoom, the boundary surface shaded by its face normals, an
// optional clipping plane. Cells are coloured by quality (flat: each triangle has its
// own vertices in the glb); edges are an optional layer (they cost about 3x to draw).
// A 2D canvas overlay, in the same coordinates, draws the domain, regions and axis.

import { STOPS } from "./colors.js";

const VS = `#version 300 es
in vec3 aPos;
in float aValue;
uniform mat4 uMvp;
uniform mat4 uMv;
uniform float uPointSize;
uniform float uDepthBias;
out float vValue;
out vec3 vView;
out vec3 vModel;
void main() {
  vValue = aValue;
  vModel = aPos;
  vView = (uMv * vec4(aPos, 1.0)).xyz;
  gl_Position = uMvp * vec4(aPos, 1.0);
  gl_Position.z -= uDepthBias * gl_Position.w;
  gl_PointSize = uPointSize;
}`;

const FS = `#version 300 es
precision highp float;
in float vValue;
in vec3 vView;
in vec3 vModel;
uniform int uColorBy;   // 0: flat uColor, 1: the value through the colour map
uniform vec3 uColor;
uniform int uShade;
uniform int uClipOn;
uniform vec4 uClip;
uniform vec3 uStops[5];
out vec4 outColor;
vec3 colormap(float t) {
  float x = clamp(t, 0.0, 1.0) * 4.0;
  int i = int(min(floor(x), 3.0));
  return mix(uStops[i], uStops[i + 1], x - float(i));
}
void main() {
  if (uClipOn == 1 && dot(uClip.xyz, vModel) + uClip.w < 0.0) discard;
  vec3 c = uColorBy == 1 ? colormap(vValue) : uColor;
  if (uShade == 1) {
    vec3 n = normalize(cross(dFdx(vView), dFdy(vView)));
    c *= 0.35 + 0.65 * abs(n.z);
  }
  outColor = vec4(c, 1.0);
}`;

export const BACKGROUND = [0.957, 0.965, 0.976];

function compile(gl, type, src) {
  const s = gl.createShader(type);
  gl.shaderSource(s, src);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
  return s;
}

// ------------------------------------------------------------------ small mat4 (column-major)

function multiply(a, b) {
  const o = new Float32Array(16);
  for (let c = 0; c < 4; c++) {
    for (let r = 0; r < 4; r++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      o[c * 4 + r] = s;
    }
  }
  return o;
}

function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2);
  const nf = 1 / (near - far);
  return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0]);
}

function orbitView(yaw, pitch, distance, target) {
  // camera on a sphere around target, z up
  const cp = Math.cos(pitch), sp = Math.sin(pitch), cy = Math.cos(yaw), sy = Math.sin(yaw);
  const eye = [target[0] + distance * cp * cy, target[1] + distance * cp * sy, target[2] + distance * sp];
  const f = norm([target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]]);
  const s = norm(cross(f, [0, 0, 1]));
  const u = cross(s, f);
  return new Float32Array([
    s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
    -dot(s, eye), -dot(u, eye), dot(f, eye), 1,
  ]);
}

const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const norm = (a) => { const l = Math.hypot(...a) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };

// ------------------------------------------------------------------ viewer

export class Viewer {
  constructor(canvas, overlay) {
    this.canvas = canvas;
    this.overlay = overlay;
    const gl = canvas.getContext("webgl2", { antialias: false, powerPreference: "high-performance" });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    const prog = gl.createProgram();
    gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, FS));
    gl.bindAttribLocation(prog, 0, "aPos");
    gl.bindAttribLocation(prog, 1, "aValue");
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
    this.prog = prog;
    this.u = {};
    for (const n of ["uMvp", "uMv", "uPointSize", "uDepthBias", "uColorBy", "uColor", "uShade", "uClipOn", "uClip", "uStops"]) {
      this.u[n] = gl.getUniformLocation(prog, n);
    }
    this.layers = [];
    this.wireframe = false;
    this.clip = { on: false, axis: 0, at: 0.5 };
    this.drawOverlay = null;
    this.is3d = false;
    this.bounds = null;
    this.timings = {};
    this._pending = false;
    this._firstFrame = null;
    this._pointer(canvas);
    new ResizeObserver(() => this.requestRender()).observe(canvas);
  }

  /** Show a parsed glb (see glb.js), framed to `bounds` if given; resolves with the
   * first frame's milliseconds once it is drawn. */
  setModel(model, bounds = null) {
    const gl = this.gl;
    for (const layer of this.layers) {
      for (const b of layer.buffers) gl.deleteBuffer(b);
      gl.deleteVertexArray(layer.vao);
    }
    this.layers = [];
    let [lo, hi] = [[Infinity, Infinity, Infinity], [-Infinity, -Infinity, -Infinity]];
    for (const p of model.primitives) {
      if (!p.position) continue;
      p.position.min?.forEach((v, k) => { lo[k] = Math.min(lo[k], v); });
      p.position.max?.forEach((v, k) => { hi[k] = Math.max(hi[k], v); });
      this.layers.push(this._upload(p));
    }
    if (bounds) [lo, hi] = [[...bounds.lo], [...bounds.hi]];
    if (!Number.isFinite(lo[0])) [lo, hi] = [[0, 0, 0], [1, 1, 0]];
    this.translation = model.translation;
    this.bounds = { lo, hi };
    this.is3d = model.is3d ?? hi[2] - lo[2] > 1e-12 * Math.max(hi[0] - lo[0], hi[1] - lo[1], 1e-300);
    this.resetView();
    return new Promise((resolve) => {
      this._firstFrame = resolve;
      this.requestRender();
    });
  }

  _upload(p) {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const buffers = [];
    const attribute = (loc, array, size) => {
      const b = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.bufferData(gl.ARRAY_BUFFER, array, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, gl.FLOAT, false, 0, 0);
      buffers.push(b);
    };
    attribute(0, p.position.array, 3);
    let value = null;
    let range = null;
    if (p.quality) value = p.quality.array;
    else if (p.radius) {
      const r = p.radius.array;
      let [a, b] = [Infinity, -Infinity];
      for (let i = 0; i < r.length; i++) { if (r[i] < a) a = r[i]; if (r[i] > b) b = r[i]; }
      range = [a, b];
      value = new Float32Array(r.length);
      for (let i = 0; i < r.length; i++) value[i] = b > a ? (r[i] - a) / (b - a) : 0.5;
    }
    if (value) attribute(1, value, 1);
    else gl.vertexAttrib1f(1, 0);
    let count = p.position.count;
    if (p.indices) {
      const b = gl.createBuffer();
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, b);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, p.indices.array, gl.STATIC_DRAW);
      buffers.push(b);
      count = p.indices.count;
    }
    gl.bindVertexArray(null);
    return { vao, buffers, count, indexed: Boolean(p.indices), mode: p.mode, layer: p.layer, colored: Boolean(value), radiusRange: range };
  }

  layer(name) {
    return this.layers.find((l) => l.layer === name) || null;
  }

  // ------------------------------------------------------------------ camera

  resetView() {
    const { lo, hi } = this.bounds || { lo: [0, 0, 0], hi: [1, 1, 0] };
    const size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    this.center = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    this.radius = Math.max(Math.hypot(...size) / 2, 1e-12);
    this.span = Math.max(size[0], size[1], 1e-12) * 1.08; // 2D: world units across the short side
    this.yaw = -Math.PI / 3;
    this.pitch = Math.PI / 6;
    this.distance = this.radius * 2.8;
    this.requestRender();
  }

  orbit(dyaw, dpitch) {
    this.yaw += dyaw;
    this.pitch = Math.max(-1.55, Math.min(1.55, this.pitch + dpitch));
    this.requestRender();
  }

  pan(dx, dy) {
    // dx, dy in fractions of the view
    const k = this.is3d ? this.distance * 0.8 : this.span;
    if (this.is3d) {
      const cy = Math.cos(this.yaw), sy = Math.sin(this.yaw);
      this.center = [this.center[0] + k * (-sy * dx), this.center[1] + k * (cy * dx), this.center[2] + k * dy];
    } else {
      this.center = [this.center[0] + k * dx, this.center[1] + k * dy, this.center[2]];
    }
    this.requestRender();
  }

  zoom(f) {
    if (this.is3d) this.distance *= f;
    else this.span *= f;
    this.requestRender();
  }

  _matrices() {
    const w = this.canvas.width, h = this.canvas.height;
    if (this.is3d) {
      const mv = orbitView(this.yaw, this.pitch, this.distance, this.center);
      const near = Math.max(this.distance - this.radius * 2, this.distance * 1e-3);
      const proj = perspective(Math.PI / 4, w / h, near, this.distance + this.radius * 2);
      return { mv, mvp: multiply(proj, mv) };
    }
    const s = 2 / this.span;
    const sx = (s * Math.min(w, h)) / w, sy = (s * Math.min(w, h)) / h;
    const m = new Float32Array([sx, 0, 0, 0, 0, sy, 0, 0, 0, 0, -1e-3, 0, -sx * this.center[0], -sy * this.center[1], 0, 1]);
    return { mv: m, mvp: m };
  }

  /** Model coordinates (relative to the translation) -> CSS pixels of the canvas (2D). */
  toScreen(x, y) {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    const s = Math.min(w, h) / this.span;
    return [w / 2 + (x - this.center[0]) * s, h / 2 - (y - this.center[1]) * s];
  }

  // ------------------------------------------------------------------ drawing

  requestRender() {
    if (this._pending) return;
    this._pending = true;
    requestAnimationFrame(() => {
      this._pending = false;
      this.renderNow(Boolean(this._firstFrame));
    });
  }

  /** Draw now; with `sync`, wait for the GPU (a one-pixel read) so that the returned
   * milliseconds are the frame's (the first frame of a model, and benchmarks). */
  renderNow(sync = true) {
    const t0 = performance.now();
    const { gl, canvas } = this;
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(canvas.clientWidth * dpr));
    const h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, w, h);
    gl.clearColor(...BACKGROUND, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (this.layers.length) this._drawLayers();
    if (sync) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    this._overlay();
    const ms = performance.now() - t0;
    if (this._firstFrame) {
      this.timings.firstFrame = performance.now();
      const done = this._firstFrame;
      this._firstFrame = null;
      done(ms);
    }
    return ms;
  }

  _drawLayers() {
    const gl = this.gl;
    const { mv, mvp } = this._matrices();
    gl.useProgram(this.prog);
    gl.uniformMatrix4fv(this.u.uMvp, false, mvp);
    gl.uniformMatrix4fv(this.u.uMv, false, mv);
    gl.uniform3fv(this.u.uStops, STOPS.flat());
    gl.uniform1f(this.u.uPointSize, 4 * (window.devicePixelRatio || 1));
    const { lo, hi } = this.bounds;
    const ax = this.clip.axis;
    const plane = [0, 0, 0, 0];
    plane[ax] = -1;
    plane[3] = lo[ax] + (hi[ax] - lo[ax]) * this.clip.at;
    gl.uniform1i(this.u.uClipOn, this.is3d && this.clip.on ? 1 : 0);
    gl.uniform4fv(this.u.uClip, plane);
    if (this.is3d) gl.enable(gl.DEPTH_TEST);
    else gl.disable(gl.DEPTH_TEST);
    for (const l of this.layers) {
      if (l.layer === "edges" && !this.wireframe) continue;
      gl.bindVertexArray(l.vao);
      const cells = l.layer === "cells";
      gl.uniform1i(this.u.uShade, cells && this.is3d ? 1 : 0);
      // lines drawn on faces are pulled towards the eye so that they show whole
      gl.uniform1f(this.u.uDepthBias, cells ? 0 : 1e-3);
      gl.uniform1i(this.u.uColorBy, l.colored ? 1 : 0);
      gl.uniform3fv(this.u.uColor, l.layer === "edges" ? [0.12, 0.14, 0.18] : [0.1, 0.25, 0.55]);
      if (l.indexed) gl.drawElements(l.mode, l.count, gl.UNSIGNED_INT, 0);
      else gl.drawArrays(l.mode, 0, l.count);
    }
    gl.bindVertexArray(null);
  }

  _overlay() {
    const o = this.overlay;
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(o.clientWidth * dpr));
    const h = Math.max(1, Math.round(o.clientHeight * dpr));
    if (o.width !== w || o.height !== h) { o.width = w; o.height = h; }
    const ctx = o.getContext("2d");
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, w, h);
    if (this.is3d || !this.drawOverlay) return;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const t = this.translation || [0, 0, 0];
    this.drawOverlay(ctx, (x, y) => this.toScreen(x - t[0], y - t[1]));
  }

  // ------------------------------------------------------------------ input

  _pointer(canvas) {
    let drag = null;
    canvas.addEventListener("pointerdown", (e) => {
      canvas.focus();
      canvas.setPointerCapture(e.pointerId);
      drag = { x: e.clientX, y: e.clientY, shift: e.shiftKey };
    });
    canvas.addEventListener("pointermove", (e) => {
      if (!drag) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      const size = Math.min(canvas.clientWidth, canvas.clientHeight) || 1;
      if (this.is3d && !drag.shift) this.orbit(-dx * 0.01, dy * 0.01);
      else this.pan(-dx / size, dy / size);
    });
    const end = () => { drag = null; };
    canvas.addEventListener("pointerup", end);
    canvas.addEventListener("pointercancel", end);
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      this.zoom(e.deltaY > 0 ? 1.15 : 1 / 1.15);
    }, { passive: false });
    canvas.addEventListener("keydown", (e) => {
      const step = 0.1;
      const act = {
        ArrowLeft: () => (this.is3d ? this.orbit(step, 0) : this.pan(-step, 0)),
        ArrowRight: () => (this.is3d ? this.orbit(-step, 0) : this.pan(step, 0)),
        ArrowUp: () => (this.is3d ? this.orbit(0, step) : this.pan(0, step)),
        ArrowDown: () => (this.is3d ? this.orbit(0, -step) : this.pan(0, -step)),
        "+": () => this.zoom(1 / 1.2), "=": () => this.zoom(1 / 1.2), "-": () => this.zoom(1.2),
        "0": () => this.resetView(), Home: () => this.resetView(),
      }[e.key];
      if (act) { e.preventDefault(); act(); }
    });
  }
}
