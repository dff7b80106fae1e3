// The service's HTTP API as the page uses it: base URL, API key, problem documents,
// and the job's server-sent events read through fetch (EventSource cannot send the key).

const KEY = "meshservice.apiKey";
const BASE = "meshservice.baseUrl";

export class ApiError extends Error {
  constructor(status, problem) {
    super(problem.detail || problem.title || `HTTP ${status}`);
    this.status = status;
    this.problem = problem;
  }
}

export const settings = {
  get key() { return sessionStorage.getItem(KEY) || ""; },
  set key(v) { v ? sessionStorage.setItem(KEY, v) : sessionStorage.removeItem(KEY); },
  get base() { return localStorage.getItem(BASE) || ""; },
  set base(v) { v ? localStorage.setItem(BASE, v.replace(/\/+$/, "")) : localStorage.removeItem(BASE); },
};

function url(path) {
  return (settings.base || "") + path;
}

function headers(extra = {}) {
  const h = { ...extra };
  if (settings.key) h.Authorization = `Bearer ${settings.key}`;
  return h;
}

async function problemOf(response) {
  let doc = null;
  try { doc = await response.json(); } catch { /* not JSON */ }
  if (!doc || typeof doc !== "object") doc = { title: response.statusText, status: response.status };
  return new ApiError(response.status, doc);
}

/** fetch with the key; a non-2xx answer throws ApiError carrying the problem document. */
export async function request(path, { method = "GET", body, json, signal, accept } = {}) {
  const init = { method, headers: headers(accept ? { Accept: accept } : {}), signal };
  if (json !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(json);
  } else if (body !== undefined) {
    init.headers["Content-Type"] = "application/octet-stream";
    init.body = body;
  }
  let response;
  try {
    response = await fetch(url(path), init);
  } catch (err) {
    if (err.name === "AbortError") throw err;
    throw new ApiError(0, {
      title: "Service unreachable",
      detail: `could not reach ${url(path) || "the service"} (${err.message}); check the base URL`,
    });
  }
  if (!response.ok) throw await problemOf(response);
  return response;
}

export async function getJSON(path, opts) {
  return (await request(path, opts)).json();
}

/** Stream a job's events; calls onEvent(type, job) per event until the stream ends. */
export async function streamEvents(jobId, onEvent, signal) {
  const response = await request(`/v1/jobs/${jobId}/events`, { signal, accept: "text/event-stream" });
  const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return;
    buffer += value.replace(/\r\n/g, "\n");
    let cut;
    while ((cut = buffer.indexOf("\n\n")) >= 0) {
      const block = buffer.slice(0, cut);
      buffer = buffer.slice(cut + 2);
      let type = "message";
      const data = [];
      for (const line of block.split("\n")) {
        if (line.startsWith("event:")) type = line.slice(6).trim();
        else if (line.startsWith("data:")) data.push(line.slice(5).replace(/^ /, ""));
      }
      if (data.length) {
        const job = JSON.parse(data.join("\n"));
        onEvent(type, job);
        if (type === "end") { reader.cancel().catch(() => {}); return; }
      }
    }
  }
}

/** A human sentence for an error, with the API-key hint for 401. */
export function describe(err) {
  if (err instanceof ApiError) {
    if (err.status === 401) {
      return settings.key
        ? `The service refused the API key (401: ${err.message}). Enter a valid key under Settings.`
        : `This service needs an API key (401: ${err.message}). Enter it under Settings.`;
    }
    const title = err.problem.title && err.problem.title !== err.message ? `${err.problem.title}: ` : "";
    return `${title}${err.message}${err.status ? ` (${err.status})` : ""}`;
  }
  return String(err && err.message ? err.message : err);
}
