// The page: domain editor, method form, job runner (SSE progress, cancel), job list,
// and the result view (WebGL mesh, overlay, legend, histogram, stats, downloads).

import { ApiError, describe, getJSON, request, settings, streamEvents } from "./api.js";
import { fmt, histogram, legend } from "./charts.js";
import { color } from "./colors.js";
import { DomainEditor } from "./editor.js";
import { EXAMPLES } from "./examples.js";
import { SchemaForm } from "./form.js";
import { parseGlb } from "./glb.js";
import { Viewer } from "./viewer.js";

const $ = (id) => document.getElementById(id);
// Results whose JSON is larger than this are drawn from the glb alone (never parsed as JSON).
const JSON_LIMIT = 4 << 20;
const WIREFRAME_LIMIT = 100000;
const FALLBACK_FORMATS = ["vtu", "gmsh", "gmsh22", "xdmf", "abaqus", "obj", "stl", "ply", "glb"];

const state = {
  methods: [],
  form: null,
  mesh: null, // uploaded JSON mesh
  job: null,
  stream: null,
  pages: [null], // page tokens of the job list, newest first
  page: 0,
  formats: null,
  domainListeners: [],
  timings: {},
};

function notice(text, kind = "error") {
  const n = $("notice");
  n.textContent = text || "";
  n.dataset.kind = kind;
  n.hidden = !text;
}

function say(id, text) {
  $(id).textContent = text;
}

// ------------------------------------------------------------------ settings

function initSettings() {
  $("base-url").value = settings.base;
  $("api-key").value = settings.key;
  $("settings-form").addEventListener("submit", (e) => {
    e.preventDefault();
    settings.base = $("base-url").value.trim();
    settings.key = $("api-key").value.trim();
    notice("");
    say("settings-status", "Saved.");
    loadMethods();
    loadJobs(0);
  });
}

function apiFailure(err, where) {
  if (err instanceof ApiError && err.status === 401) {
    notice(describe(err));
    $("api-key").focus();
  } else if (where) {
    say(where, describe(err));
  } else {
    notice(describe(err));
  }
}

// ------------------------------------------------------------------ domain

let editor;

function initDomain() {
  editor = new DomainEditor($("domain-canvas"), {
    onChange: () => {
      say("domain-status", editor.prompt());
      const g = editor.geometry();
      if (document.activeElement !== $("geojson")) $("geojson").value = g ? JSON.stringify(g) : "";
      for (const f of state.domainListeners) f();
    },
    onStatus: (t) => say("domain-status", t),
  });
  say("domain-status", editor.prompt());
  $("close-ring").addEventListener("click", () => editor.closeRing());
  $("undo").addEventListener("click", () => editor.undo());
  $("clear").addEventListener("click", () => editor.clear());
  $("fit").addEventListener("click", () => editor.fit());
  $("snap").addEventListener("change", (e) => { editor.snap = e.target.checked; editor.draw(); });
  $("grid").addEventListener("change", (e) => {
    const v = Number(e.target.value);
    if (v > 0) { editor.grid = v; editor.draw(); }
  });
  $("grid").value = editor.grid;
  const examples = $("example");
  for (const name of Object.keys(EXAMPLES)) examples.append(new Option(name, name));
  examples.addEventListener("change", () => {
    if (!examples.value) return;
    editor.setGeometry(EXAMPLES[examples.value]);
    $("grid").value = editor.grid;
    examples.value = "";
  });
  $("point-form").addEventListener("submit", (e) => {
    e.preventDefault();
    const [x, y] = $("point").value.split(/[,\s]+/).filter(Boolean).map(Number);
    if (!Number.isFinite(x) || !Number.isFinite(y)) {
      say("domain-status", "Type a point as x, y");
      return;
    }
    editor.addPoint(x, y);
    $("point").value = "";
  });
  $("use-geojson").addEventListener("click", () => useGeoJSON($("geojson").value));
  $("geojson-file").addEventListener("change", async (e) => {
    const file = e.target.files[0];
    if (file) useGeoJSON(await file.text());
    e.target.value = "";
  });
}

function useGeoJSON(text) {
  try {
    let g = JSON.parse(text);
    if (g.type === "FeatureCollection") g = g.features[0]?.geometry;
    if (g && g.type === "Feature") g = g.geometry;
    if (!g || (g.type !== "Polygon" && g.type !== "MultiPolygon") || !Array.isArray(g.coordinates)) {
      throw new Error("expected a GeoJSON Polygon or MultiPolygon (or a Feature holding one)");
    }
    editor.setGeometry(g);
    say("domain-status", `Loaded a ${g.type}.`);
  } catch (err) {
    say("domain-status", `GeoJSON not used: ${err.message}`);
  }
}

/** Highlight what a domain error names: loc after "domain" and the message's segments. */
function markDomainError(rest, msg) {
  const geo = editor.geometry();
  const multi = geo && geo.type === "MultiPolygon";
  const idx = rest[0] === "coordinates" ? rest.slice(1) : [];
  const poly = multi ? idx[0] ?? 0 : 0;
  const tail = multi ? idx.slice(1) : idx;
  const segments = [];
  const vertices = [];
  for (const m of msg.matchAll(/ring (\d+): vertex (\d+) -> (\d+)/g)) {
    segments.push([poly, Number(m[1]), Number(m[2]), Number(m[3])]);
  }
  if (tail.length >= 2 && Number.isInteger(tail[1])) vertices.push([poly, tail[0], tail[1]]);
  else if (!segments.length) {
    for (const m of msg.matchAll(/ring (\d+)(?:,)? vertex (\d+)/g)) vertices.push([poly, Number(m[1]), Number(m[2])]);
  }
  editor.mark({ segments, vertices });
}

// ------------------------------------------------------------------ mesh upload

function initMeshUpload() {
  $("mesh-file").addEventListener("change", async (e) => {
    const file = e.target.files[0];
    e.target.value = "";
    if (!file) return;
    say("mesh-status", `Reading ${file.name}…`);
    try {
      let mesh;
      if (/\.json$/i.test(file.name)) {
        mesh = JSON.parse(await file.text());
        if (!Array.isArray(mesh.points) || !Array.isArray(mesh.cells)) throw new Error("a JSON mesh has points and cells");
      } else {
        const name = encodeURIComponent(file.name);
        mesh = await (await request(`/v1/convert?filename=${name}`, { method: "POST", body: file })).json();
      }
      state.mesh = mesh;
      const blocks = mesh.cells.map((c) => `${c.data.length} ${c.type}`).join(", ");
      say("mesh-status", `Uploaded ${file.name}: ${mesh.points.length} points; ${blocks}.`);
      if (state.form) selectMethod($("method").value);
    } catch (err) {
      if (err instanceof ApiError && err.status === 401) apiFailure(err);
      say("mesh-status", `Upload failed: ${describe(err)}`);
    }
  });
}

// ------------------------------------------------------------------ methods and form

async function loadMethods() {
  try {
    state.methods = await getJSON("/v1/methods");
  } catch (err) {
    apiFailure(err, "run-status");
    return;
  }
  const select = $("method");
  const keep = select.value;
  select.replaceChildren(...state.methods.map((m) => new Option(m.name, m.name)));
  const initial = state.methods.some((m) => m.name === keep) ? keep : state.methods.find((m) => m.name === "triangulate")?.name || state.methods[0]?.name;
  if (initial) {
    select.value = initial;
    selectMethod(initial);
  }
}

function selectMethod(name) {
  const spec = state.methods.find((m) => m.name === name);
  if (!spec) return;
  say("method-summary", `${spec.summary} (${spec.section})`);
  const example = spec.example || {};
  // the example's domain starts the drawing when nothing is drawn yet
  if (!editor.geometry() && example.domain && example.domain.coordinates) editor.setGeometry(example.domain);
  state.domainListeners = [];
  state.form = new SchemaForm(spec.params_schema, example, {
    domain: () => editor.geometry(),
    mesh: () => state.mesh,
    onDomainChange: (f) => state.domainListeners.push(f),
    onDomainError: markDomainError,
  });
  $("params").replaceChildren(state.form.el);
}

// ------------------------------------------------------------------ run

async function submit(e) {
  e.preventDefault();
  if (!state.form) return;
  editor.clearMarks();
  const errors = state.form.check();
  if (errors.length) {
    say("run-status", `Fix ${errors.length} field${errors.length > 1 ? "s" : ""} first: ${errors.map((x) => `${x.path.join(".") || "params"}: ${x.msg}`).join("; ")}`);
    return;
  }
  const body = { method: $("method").value, params: state.form.value() };
  state.timings = { submit: performance.now() };
  window.meshPage.timings = state.timings;
  setProgress(0, "submitting…");
  say("result-status", "Waiting for the job…");
  $("submit").disabled = true;
  try {
    const job = await getJSON("/v1/jobs", { method: "POST", json: body });
    say("run-status", `Job ${job.id} ${job.status}.`);
    follow(job);
    loadJobs(0);
  } catch (err) {
    $("submit").disabled = false;
    setProgress(0, "");
    showProblem(err);
  }
}

function showProblem(err) {
  if (err instanceof ApiError && err.status === 422 && state.form) {
    const rest = state.form.showServerErrors(err.problem.errors);
    const where = rest.length ? "" : " (see the highlighted fields)";
    say("run-status", `Refused: ${err.message}${where}`);
  } else if (err instanceof ApiError && err.status === 401) {
    apiFailure(err);
    say("run-status", describe(err));
  } else {
    say("run-status", describe(err));
  }
}

function setProgress(fraction, message) {
  $("progress").value = fraction;
  $("progress").textContent = `${Math.round(fraction * 100)} %`;
  say("progress-message", message || "");
}

async function follow(job) {
  state.stream?.abort();
  const controller = new AbortController();
  state.stream = controller;
  state.job = job;
  $("cancel").disabled = job.status === "succeeded" || job.status === "failed" || job.status === "cancelled";
  let last = job;
  const update = (type, j) => {
    last = j;
    state.job = j;
    setProgress(j.status === "succeeded" ? 1 : j.progress?.fraction ?? 0, j.progress?.message || j.status);
    say("run-status", `Job ${j.id}: ${j.status}.`);
  };
  update("progress", job);
  try {
    if (!["succeeded", "failed", "cancelled"].includes(job.status)) {
      await streamEvents(job.id, update, controller.signal);
    }
  } catch (err) {
    if (err.name === "AbortError") return;
    // the stream broke (proxy, network): fall back to long-polling
    while (!["succeeded", "failed", "cancelled"].includes(last.status)) {
      try {
        last = await getJSON(`/v1/jobs/${job.id}?wait=10`, { signal: controller.signal });
        update("progress", last);
      } catch (e) {
        if (e.name === "AbortError") return;
        say("run-status", describe(e));
        break;
      }
    }
  }
  if (state.stream !== controller) return;
  $("cancel").disabled = true;
  $("submit").disabled = false;
  loadJobs(state.page);
  if (last.status === "succeeded") {
    setProgress(1, "done");
    say("run-status", `Job ${last.id} succeeded.`);
    await showResult(last.id);
  } else if (last.status === "failed") {
    const p = last.error || {};
    if (state.form && p.errors) state.form.showServerErrors(p.errors);
    say("run-status", `Job ${last.id} failed: ${p.detail || p.title || "see its error"}`);
  } else if (last.status === "cancelled") {
    say("run-status", `Job ${last.id} was cancelled.`);
  }
}

async function cancel() {
  if (!state.job) return;
  try {
    const job = await getJSON(`/v1/jobs/${state.job.id}/cancel`, { method: "POST" });
    say("run-status", `Job ${job.id}: cancel requested (${job.status}).`);
  } catch (err) {
    showProblem(err);
  }
}

// ------------------------------------------------------------------ job list

async function loadJobs(page) {
  const token = state.pages[page];
  const q = new URLSearchParams({ page_size: "8" });
  if (token) q.set("page_token", token);
  let data;
  try {
    data = await getJSON(`/v1/jobs?${q}`);
  } catch (err) {
    apiFailure(err, "jobs-status");
    return;
  }
  state.page = page;
  state.pages[page + 1] = data.next_page_token || undefined;
  const rows = data.jobs.map((j) => {
    const tr = document.createElement("tr");
    const open = document.createElement("button");
    open.type = "button";
    open.className = "small";
    open.textContent = "Open";
    open.setAttribute("aria-label", `Open job ${j.id} (${j.method}, ${j.status})`);
    open.addEventListener("click", () => follow(j));
    for (const text of [age(j.created_at), j.method, j.status]) {
      const td = document.createElement("td");
      td.textContent = text;
      tr.append(td);
    }
    const td = document.createElement("td");
    td.append(open);
    tr.append(td);
    return tr;
  });
  $("jobs-body").replaceChildren(...rows);
  say("jobs-status", rows.length ? `Page ${page + 1}` : "No jobs yet.");
  $("newer").disabled = page === 0;
  $("older").disabled = !data.next_page_token;
}

function age(iso) {
  const s = Math.max(0, (Date.now() - Date.parse(iso)) / 1000);
  if (s < 60) return `${Math.round(s)} s ago`;
  if (s < 3600) return `${Math.round(s / 60)} min ago`;
  if (s < 86400) return `${Math.round(s / 3600)} h ago`;
  return `${Math.round(s / 86400)} d ago`;
}

// ------------------------------------------------------------------ result

let viewer;

/** The result's JSON when it is at most JSON_LIMIT bytes (read up to the limit, whatever
 * the Content-Length says), else {json: null} and the size seen. */
async function fetchResultJSON(id) {
  const controller = new AbortController();
  const response = await request(`/v1/jobs/${id}/result`, { signal: controller.signal });
  const declared = Number(response.headers.get("Content-Length") || 0);
  if (declared > JSON_LIMIT) {
    controller.abort();
    return { json: null, size: declared };
  }
  const reader = response.body.getReader();
  const chunks = [];
  let size = 0;
  for (;;) {
    const { value, done } = await reader.read();
    if (done) break;
    size += value.length;
    if (size > JSON_LIMIT) {
      controller.abort();
      return { json: null, size: Math.max(size, declared) };
    }
    chunks.push(value);
  }
  const text = new TextDecoder().decode(await new Blob(chunks).arrayBuffer());
  return { json: JSON.parse(text), size };
}

async function showResult(id) {
  say("result-status", "Loading the result…");
  $("result").hidden = false;
  let json = null;
  let size = 0;
  let model = null;
  try {
    ({ json, size } = await fetchResultJSON(id));
    if (!json || json.mesh) {
      const response = await request(`/v1/jobs/${id}/result?format=glb`);
      model = parseGlb(await response.arrayBuffer());
    }
  } catch (err) {
    if (err.name === "AbortError") return;
    say("result-status", `Result not shown: ${describe(err)}`);
    return;
  }
  state.timings.data = performance.now();
  const extras = model?.extras || {};
  const quality = json?.quality || extras.quality || null;
  const stats = json?.stats || extras.stats || null;
  const overlayOnly = !model;
  const shapes = json ? overlayShapes(json, Boolean(model)) : null;
  const shown = model || { primitives: [], translation: [0, 0, 0], is3d: false };
  // edges cost about 3x to draw: on by default for small meshes only
  const drawn = shown.primitives.find((p) => p.layer === "cells");
  viewer.wireframe = $("wireframe").checked = Boolean(drawn) && drawn.position.count / 3 <= WIREFRAME_LIMIT;
  const ms = await viewer.setModel(shown, overlayOnly && shapes ? shapes.bounds : null);
  viewer.drawOverlay = shapes ? (ctx, P) => drawShapes(ctx, P, shapes) : null;
  viewer.requestRender();
  state.timings.firstFrame = performance.now();
  const cells = viewer.layer("cells");
  $("view-kind").textContent = viewer.is3d
    ? "3D view: drag or arrow keys to orbit, Shift+drag to pan, wheel or +/- to zoom, 0 to reset."
    : "2D view: drag or arrow keys to pan, wheel or +/- to zoom, 0 to reset.";
  $("clip-controls").hidden = !viewer.is3d;
  $("wireframe").disabled = !viewer.layer("edges");
  const legends = [];
  if (cells) legends.push(legend("quality", "0 poor", "1 ideal"));
  const radius = viewer.layers.find((l) => l.radiusRange);
  if (radius) legends.push(legend("radius", fmt(radius.radiusRange[0]), fmt(radius.radiusRange[1])));
  else if (shapes?.radius) legends.push(legend("radius", fmt(shapes.radius[0]), fmt(shapes.radius[1])));
  $("legend").replaceChildren(...legends);
  showQuality(quality);
  showStats(stats);
  await showDownloads(id, Boolean(json ? json.mesh : model));
  const triangles = cells ? cells.count / 3 : 0;
  say("result-status", `Job ${id}: ${triangles ? `${triangles} triangles drawn` : "drawn"}${json ? "" : ` from the glb (the JSON is ${(size / 1e6).toFixed(0)} MB)`}; first frame ${ms.toFixed(0)} ms.`);
}

/** What the 2D overlay draws: the domain, the regions (filled unless a mesh is drawn under
 * them: its quality colours must stay true) and the medial axis coloured by radius. */
function overlayShapes(json, withMesh) {
  const rings = (g) => (g.type === "MultiPolygon" ? g.coordinates.flat() : g.coordinates);
  const shapes = {
    domain: json.domain?.coordinates ? rings(json.domain) : [],
    regions: (json.regions || []).filter((r) => r && r.coordinates).map(rings),
    fill: !withMesh,
    axis: null,
    radius: null,
  };
  if (json.axis) {
    const r = json.axis.radius || [];
    shapes.axis = json.axis;
    shapes.radius = r.length ? r.reduce(([a, b], v) => [Math.min(a, v), Math.max(b, v)], [Infinity, -Infinity]) : null;
  }
  let [x0, y0, x1, y1] = [Infinity, Infinity, -Infinity, -Infinity];
  const grow = ([x, y]) => { x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y); };
  shapes.domain.flat().forEach(grow);
  shapes.regions.flat(2).forEach(grow);
  (json.axis?.nodes || []).forEach(grow);
  shapes.bounds = Number.isFinite(x0) ? { lo: [x0, y0, 0], hi: [x1, y1, 0] } : null;
  return shapes;
}

function drawShapes(ctx, P, shapes) {
  const ring = (r) => r.forEach((p, i) => (i ? ctx.lineTo(...P(p[0], p[1])) : ctx.moveTo(...P(p[0], p[1]))));
  shapes.regions.forEach((rs, i) => {
    ctx.beginPath();
    rs.forEach((r) => { ring(r); ctx.closePath(); });
    if (shapes.fill) {
      ctx.fillStyle = `hsla(${(i * 137.5) % 360}, 65%, 55%, 0.45)`;
      ctx.fill("evenodd");
    }
    ctx.strokeStyle = "rgba(20, 20, 30, 0.8)";
    ctx.lineWidth = shapes.fill ? 1 : 2;
    ctx.stroke();
  });
  if (shapes.domain.length) {
    ctx.beginPath();
    shapes.domain.forEach((r) => { ring(r); ctx.closePath(); });
    ctx.strokeStyle = "#111";
    ctx.lineWidth = 1.5;
    ctx.stroke();
  }
  const axis = shapes.axis;
  if (axis) {
    const [lo, hi] = shapes.radius || [0, 1];
    ctx.lineWidth = 2.5;
    for (const [a, b] of axis.edges) {
      const t = hi > lo ? ((axis.radius[a] + axis.radius[b]) / 2 - lo) / (hi - lo) : 0.5;
      ctx.strokeStyle = color(t);
      ctx.beginPath();
      ctx.moveTo(...P(...axis.nodes[a]));
      ctx.lineTo(...P(...axis.nodes[b]));
      ctx.stroke();
    }
  }
}

function showQuality(quality) {
  const charts = [];
  const rows = [];
  for (const [type, entry] of Object.entries(quality || {})) {
    if (!entry || typeof entry !== "object" || !("count" in entry)) continue;
    if (entry.quality) charts.push(histogram(type, entry));
    rows.push([type, entry.count, entry.invalid ?? "–", fmt(entry.quality?.min), fmt(entry.quality?.mean), fmt(entry.quality?.max), fmt(entry.angle?.min), fmt(entry.angle?.max)]);
  }
  $("histograms").replaceChildren(...charts);
  $("histogram-box").hidden = !charts.length;
  const table = $("quality-table");
  table.hidden = !rows.length;
  table.tBodies[0].replaceChildren(...rows.map((r) => tableRow(r)));
  const c = quality?.conformity;
  say("conformity", c ? `Conformity: ${c.nonmanifold} non-manifold facets, ${c.boundary_edges} boundary edges not on the input boundary.` : "");
}

/** A table row, its first cell the row's header. */
function tableRow(cells) {
  const tr = document.createElement("tr");
  cells.forEach((c, i) => {
    const td = document.createElement(i === 0 ? "th" : "td");
    if (i === 0) td.scope = "row";
    td.textContent = String(c);
    tr.append(td);
  });
  return tr;
}

function showStats(stats) {
  const show = (v) => {
    if (Array.isArray(v)) return v.map(show).join(", ");
    if (v && typeof v === "object") return Object.entries(v).map(([k, x]) => `${k}: ${show(x)}`).join(", ");
    return fmt(v);
  };
  const rows = Object.entries(stats || {}).map(([k, v]) => tableRow([k, show(v)]));
  $("stats-body").replaceChildren(...rows);
  $("stats-table").hidden = !rows.length;
}

async function formats() {
  if (state.formats) return state.formats;
  try {
    const spec = await getJSON("/openapi.json");
    const params = spec.paths["/v1/jobs/{job_id}/result"].get.parameters;
    const schema = params.find((p) => p.name === "format").schema;
    const found = (schema.anyOf || [schema]).find((s) => s.enum);
    state.formats = found ? found.enum : FALLBACK_FORMATS;
  } catch {
    state.formats = FALLBACK_FORMATS;
  }
  return state.formats;
}

async function showDownloads(id, hasMesh) {
  const box = $("downloads");
  $("downloads-h").hidden = !hasMesh;
  if (!hasMesh) {
    box.replaceChildren();
    return;
  }
  const buttons = (await formats()).map((f) => {
    const b = document.createElement("button");
    b.type = "button";
    b.className = "small";
    b.textContent = f;
    b.setAttribute("aria-label", `Download the mesh as ${f}`);
    b.addEventListener("click", () => download(id, f));
    return b;
  });
  box.replaceChildren(...buttons);
}

async function download(id, format) {
  say("download-status", `Preparing ${format}…`);
  try {
    const response = await request(`/v1/jobs/${id}/result?format=${format}`);
    const name = /filename="?([^";]+)"?/.exec(response.headers.get("Content-Disposition") || "")?.[1] || `${id}.${format}`;
    const blob = await response.blob();
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = name;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 60000);
    say("download-status", `Downloaded ${name} (${blob.size} bytes).`);
  } catch (err) {
    say("download-status", `No ${format} download: ${describe(err)}`);
  }
}

function initResult() {
  try {
    viewer = new Viewer($("view"), $("view-overlay"));
  } catch (err) {
    say("result-status", `The result view needs WebGL2: ${err.message}`);
    return;
  }
  $("wireframe").addEventListener("change", (e) => { viewer.wireframe = e.target.checked; viewer.requestRender(); });
  $("clip").addEventListener("change", (e) => { viewer.clip.on = e.target.checked; viewer.requestRender(); });
  $("clip-axis").addEventListener("change", (e) => { viewer.clip.axis = Number(e.target.value); viewer.requestRender(); });
  $("clip-at").addEventListener("input", (e) => { viewer.clip.at = Number(e.target.value); viewer.requestRender(); });
  $("reset-view").addEventListener("click", () => viewer.resetView());
}

// ------------------------------------------------------------------ start

function start() {
  initSettings();
  initDomain();
  initMeshUpload();
  initResult();
  $("method").addEventListener("change", (e) => selectMethod(e.target.value));
  $("run-form").addEventListener("submit", submit);
  $("cancel").addEventListener("click", cancel);
  $("newer").addEventListener("click", () => loadJobs(Math.max(0, state.page - 1)));
  $("older").addEventListener("click", () => loadJobs(state.page + 1));
  $("refresh-jobs").addEventListener("click", () => loadJobs(0));
  window.meshPage = { editor, viewer, timings: state.timings, state };
  loadMethods();
  loadJobs(0);
}

start();
