// Submit a study: paste or upload a spec. As you type, the spec is checked against the schema
// the server serves (GET /v1/study.schema.json, JSON Schema 2020-12, validated in the page by
// the vendored @cfworker/json-schema); POST /v1/studies then runs the server's own checks, and
// its problem+json errors are shown next to the field they point at, like the schema's. The
// request carries the bearer token when one is set, and an Idempotency-Key that stays the same
// until the text changes, so a double click (or a retry after a lost answer) makes one study.
import { Validator } from "../../vendor/cfworker-json-schema-4.1.6/index.js";
import { api, randomKey, ApiError } from "../api.js";
import { h, replace, errorBox } from "../dom.js";
import { modelsOf } from "../models.js";

/** An example map over the server's friction models (models.js; none known: the base's). */
function example(models) {
  const axes = [{ name: "va_over_vd", values: [0, 0.5, 1, 2, 4, 6] }];
  if (models.length) axes.unshift({ name: "model", values: models });
  return {
    name: "example-map",
    stages: [{ duration: 2 }, { duration: 2, v_a: 0, f: 1500 }],
    integrator: { kind: "rk4", dt: 1e-5 },
    design: { type: "grid", axes },
  };
}

// Keywords that only say "something below failed": shown only when nothing more precise is.
const CONTAINERS = new Set(["properties", "items", "prefixItems", "additionalProperties", "unevaluatedProperties", "$ref", "allOf", "anyOf", "oneOf", "if", "then", "else", "dependentSchemas", "contains", "propertyNames", "$recursiveRef"]);

/** "#/design/axes/0" (cfworker's URI-encoded location) -> "/design/axes/0". */
function pointerOf(location) {
  return location
    .replace(/^#/, "")
    .split("/")
    .map((s) => {
      try {
        return decodeURIComponent(s);
      } catch (_) {
        return s;
      }
    })
    .join("/");
}

const within = (p, ancestor) => p === ancestor || p.startsWith(ancestor + "/") || ancestor === "";

/** The schema's errors worth showing: leaves, with their JSON pointers. */
export function schemaErrors(result) {
  const errs = result.errors.map((e) => ({ pointer: pointerOf(e.instanceLocation), keyword: e.keyword, detail: e.keyword === "false" ? "unknown field (not allowed here)" : e.error }));
  const leaves = errs.filter((e) => !CONTAINERS.has(e.keyword));
  const kept = errs.filter((e) => !CONTAINERS.has(e.keyword) || !leaves.some((l) => within(l.pointer, e.pointer)));
  const seen = new Set();
  return kept.filter((e) => {
    const k = e.pointer + "|" + e.detail;
    if (seen.has(k)) return false;
    seen.add(k);
    return true;
  });
}

const esc = (k) => String(k).replace(/~/g, "~0").replace(/\//g, "~1");

/** The spec as an outline, one line per field, each with data-pointer (its JSON pointer). */
function outline(value) {
  const box = h("div", { class: "fields", id: "spec-fields" });
  function walk(v, key, pointer, depth) {
    const line = h("div", { class: "line indent-" + Math.min(depth, 6) });
    if (key !== null) line.append(h("span", { class: "key" }, key), ": ");
    const row = h("div", { class: "field", dataset: { pointer } }, line);
    box.appendChild(row);
    if (v !== null && typeof v === "object") {
      line.append(h("span", { class: "muted" }, Array.isArray(v) ? "[" + v.length + "]" : "{…}"));
      for (const [k, child] of Object.entries(v)) walk(child, Array.isArray(v) ? "[" + k + "]" : k, pointer + "/" + esc(k), depth + 1);
    } else {
      line.append(h("span", { class: "value" }, JSON.stringify(v)));
    }
  }
  walk(value, null, "", 0);
  return box;
}

/** Puts each error under the line of its field (or of the nearest field that exists). */
function attach(fields, general, errors, source) {
  for (const e of errors) {
    let p = e.pointer;
    let row = null;
    while (true) {
      row = fields.querySelector('[data-pointer="' + CSS.escape(p) + '"]');
      if (row || p === "") break;
      p = p.slice(0, p.lastIndexOf("/"));
    }
    const msg = h("div", { class: "field-error", dataset: { pointer: e.pointer, source } }, h("span", { class: "source" }, source), e.pointer && e.pointer !== p ? e.pointer + ": " : "", e.detail);
    if (row) {
      row.classList.add("has-error");
      row.appendChild(msg);
    } else {
      general.appendChild(msg);
    }
  }
}

export async function render(main, params, query, alive) {
  const root = h("div");
  main.appendChild(root);
  let schema = null, validator = null, schemaProblem = null;
  try {
    schema = await api.get("/v1/study.schema.json");
    validator = new Validator(schema, "2020-12", false);
  } catch (err) {
    schemaProblem = err;
  }
  if (!alive()) return null;

  const text = h("textarea", { id: "spec-text", spellcheck: "false", "aria-label": "study spec (JSON)" });
  text.value = JSON.stringify(example(modelsOf(schema)), null, 2);
  const file = h("input", { type: "file", accept: ".json,application/json", id: "spec-file" });
  const exampleBtn = h("button", { type: "button" }, "Example");
  const submitBtn = h("button", { type: "button", class: "primary", id: "submit-study" }, "Submit");
  const summary = h("div", { id: "validation-summary" });
  const general = h("div", { id: "general-errors" });
  const fieldsBox = h("div", { class: "outline" });
  const result = h("div", { id: "submit-result" });
  root.appendChild(
    h(
      "div",
      { class: "card" },
      h("h1", null, "Submit a study"),
      h("p", { class: "muted" }, "Paste a spec (schemas/study.schema.json, SI units) or upload a file. It is checked against the server's schema as you type; the server checks it again on submit. ", h("a", { href: "/v1/study.schema.json" }, "The schema")),
      h("div", { class: "row" }, file, exampleBtn, h("span", { class: "spacer" }), submitBtn),
      result,
      h("div", { class: "submit-grid" }, h("div", null, text), h("div", null, summary, general, fieldsBox)),
    ),
  );
  if (schemaProblem) summary.appendChild(errorBox(schemaProblem));

  let key = randomKey(); // one Idempotency-Key per text: a new one when the text changes
  let serverErrors = [];
  let timer = null;

  function check() {
    replace(general);
    let doc;
    try {
      doc = JSON.parse(text.value);
    } catch (err) {
      replace(summary, h("div", { class: "error-box", id: "json-error" }, "Not JSON: " + err.message));
      replace(fieldsBox);
      return;
    }
    const fields = outline(doc);
    replace(fieldsBox, fields);
    const errs = validator ? schemaErrors(validator.validate(doc)) : [];
    attach(fields, general, errs, "schema");
    attach(fields, general, serverErrors, "server");
    const all = [...errs.map((e) => ["schema", e]), ...serverErrors.map((e) => ["server", e])];
    if (!all.length) {
      replace(summary, h("div", { class: "ok-box", id: "spec-valid" }, validator ? "Valid against the server's schema." : "JSON parsed (schema not loaded)."));
      return;
    }
    // A short list on top (each entry jumps to its field), and each message under its field.
    const list = h("ul", { class: "problems" });
    for (const [source, e] of all) {
      const a = h("a", { href: "#" }, e.pointer || "(the whole spec)");
      a.addEventListener("click", (ev) => {
        ev.preventDefault();
        reveal(fields.querySelector('.field-error[data-pointer="' + CSS.escape(e.pointer) + '"]'));
      });
      list.appendChild(h("li", null, h("span", { class: "source-tag" }, source), " ", a, ": ", e.detail));
    }
    replace(summary, h("div", { class: "error-box" }, all.length + " problem(s), marked below:", list));
    reveal(fields.querySelector(".field-error"));
  }
  /** Scrolls the outline (not the page) to an element of it. */
  function reveal(el) {
    if (!el) return;
    fieldsBox.scrollTop = Math.max(0, el.offsetTop - 60);  // .outline is the offsetParent
  }
  function changed() {
    key = randomKey();
    serverErrors = [];
    clearTimeout(timer);
    timer = setTimeout(check, 250);
  }
  text.addEventListener("input", changed);
  exampleBtn.addEventListener("click", () => {
    text.value = JSON.stringify(example(modelsOf(schema)), null, 2);
    changed();
  });
  file.addEventListener("change", async () => {
    const f = file.files && file.files[0];
    if (!f) return;
    text.value = await f.text();
    changed();
  });

  let inFlight = false;
  async function submit() {
    if (inFlight) return; // the same key would make a replay anyway
    inFlight = true;
    submitBtn.disabled = true;
    replace(result);
    try {
      const r = await api.post("/v1/studies", text.value, { "Idempotency-Key": key });
      const s = r.data;
      const replayed = r.headers.get("Idempotent-Replayed") === "true";
      serverErrors = [];
      replace(
        result,
        h("div", { class: "ok-box", id: "submitted" }, replayed ? "Already submitted (same text, same Idempotency-Key): " : "Submitted: ", h("a", { href: "#/studies/" + encodeURIComponent(s.id), id: "submitted-link" }, s.name), " (" + s.id + "). ", h("a", { href: "#/studies" }, "All studies")),
      );
    } catch (err) {
      if (err instanceof ApiError && err.problem) {
        serverErrors = (err.problem.errors || []).filter((e) => e.pointer !== undefined).map((e) => ({ pointer: e.pointer, detail: e.detail }));
        const other = (err.problem.errors || []).filter((e) => e.pointer === undefined);
        if (err.status === 401 || err.status === 403) window.stickslip.askForToken();
        replace(result, h("div", { class: "error-box", id: "server-problem" }, (err.problem.title || "Error") + " (" + err.status + "): " + (err.problem.detail || ""), other.map((e) => "\n" + (e.header || e.parameter) + ": " + e.detail)));
      } else {
        replace(result, errorBox(err));
      }
    }
    check();
    inFlight = false;
    submitBtn.disabled = false;
  }
  submitBtn.addEventListener("click", submit);
  check();
  document.body.dataset.page = "submit";
  return () => clearTimeout(timer);
}
