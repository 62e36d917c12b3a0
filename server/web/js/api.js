// The /v1 API as the command line uses it: same endpoints, same problem+json errors. The bearer
// token (only needed for writes when the server has one) lives in this tab's session storage;
// nothing ever writes it into the page.

const TOKEN_KEY = "stickslip.token";

export const token = {
  isSet() {
    return !!sessionStorage.getItem(TOKEN_KEY);
  },
  set(value) {
    if (value) sessionStorage.setItem(TOKEN_KEY, value);
    else sessionStorage.removeItem(TOKEN_KEY);
    window.dispatchEvent(new Event("stickslip-token"));
  },
  header() {
    const t = sessionStorage.getItem(TOKEN_KEY);
    return t ? { Authorization: "Bearer " + t } : {};
  },
};

/** A non-2xx answer; .problem is the problem+json body when there is one. */
export class ApiError extends Error {
  constructor(status, problem, text) {
    super(problem && problem.detail ? problem.detail : "HTTP " + status + (text ? ": " + text.slice(0, 200) : ""));
    this.status = status;
    this.problem = problem;
  }
}

async function parse(resp) {
  const type = resp.headers.get("Content-Type") || "";
  if (resp.status === 204) return null;
  if (type.includes("json")) return resp.json();
  return resp.text();
}

async function request(method, path, { body, headers, signal } = {}) {
  const h = Object.assign({ Accept: "application/json" }, headers || {});
  if (method !== "GET") Object.assign(h, token.header());
  if (body !== undefined) h["Content-Type"] = "application/json";
  const resp = await fetch(path, { method, headers: h, body, signal, cache: "no-store" });
  const data = await parse(resp);
  if (!resp.ok) {
    const problem = data && typeof data === "object" ? data : null;
    throw new ApiError(resp.status, problem, typeof data === "string" ? data : "");
  }
  return { status: resp.status, data, headers: resp.headers };
}

export const api = {
  async get(path, opts) {
    return (await request("GET", path, opts)).data;
  },
  async text(path) {
    const resp = await fetch(path, { cache: "no-store" });
    if (!resp.ok) throw new ApiError(resp.status, null, await resp.text());
    return resp.text();
  },
  /** POST a JSON text (sent as is, so the server sees exactly what was typed). */
  post(path, bodyText, headers) {
    return request("POST", path, { body: bodyText, headers });
  },
};

/** Query string from an object, skipping empty values. */
export function qs(params) {
  const u = new URLSearchParams();
  for (const [k, v] of Object.entries(params)) if (v !== undefined && v !== null && v !== "") u.set(k, v);
  const s = u.toString();
  return s ? "?" + s : "";
}

export const enc = encodeURIComponent;

/** A random key for Idempotency-Key (crypto.getRandomValues works on plain http too). */
export function randomKey() {
  const b = new Uint8Array(16);
  crypto.getRandomValues(b);
  return "ui-" + Array.from(b, (x) => x.toString(16).padStart(2, "0")).join("");
}
