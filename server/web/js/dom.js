// DOM helpers. Every value from the server becomes a text node (textContent), never markup:
// nothing here parses HTML, so a study named "<script>alert(1)</script>" is shown as those
// characters. Attributes are set one by one with setAttribute (no on* handlers: listeners only).

/** h("a", {href: "#/x", class: "y"}, "text", child, ...) -> element. null/undefined/false
 * children are skipped; strings and numbers become text nodes; arrays are flattened. */
export function h(tag, attrs, ...children) {
  const el = document.createElement(tag);
  if (attrs) {
    for (const [k, v] of Object.entries(attrs)) {
      if (v === null || v === undefined || v === false) continue;
      if (k === "on") {
        for (const [type, fn] of Object.entries(v)) el.addEventListener(type, fn);
      } else if (k === "dataset") {
        for (const [dk, dv] of Object.entries(v)) el.dataset[dk] = String(dv);
      } else if (k.startsWith("on")) {
        throw new Error("inline handlers are not allowed: use {on: {...}}");
      } else if (k === "value" || k === "checked" || k === "disabled" || k === "selected") {
        el[k] = v;
      } else {
        el.setAttribute(k, v === true ? "" : String(v));
      }
    }
  }
  append(el, children);
  return el;
}

export function append(el, children) {
  for (const c of children) {
    if (c === null || c === undefined || c === false) continue;
    if (Array.isArray(c)) append(el, c);
    else if (c instanceof Node) el.appendChild(c);
    else el.appendChild(document.createTextNode(String(c)));
  }
  return el;
}

export function clear(el) {
  while (el.firstChild) el.removeChild(el.firstChild);
  return el;
}

/** Replaces the children of el. */
export function replace(el, ...children) {
  clear(el);
  return append(el, children);
}

/** A number for people: up to `digits` significant digits, "–" for null/NaN. */
export function num(v, digits = 4) {
  if (v === null || v === undefined || Number.isNaN(v)) return "–";
  if (typeof v !== "number") return String(v);
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-4) return v.toExponential(digits - 1);
  return Number(v.toPrecision(digits)).toString();
}

export function pct(done, total) {
  if (!total) return 0;
  return Math.min(100, Math.round((100 * done) / total));
}

/** "2026-11-25T10:43:39.123Z" -> "2026-11-25 10:43:39" (UTC), "–" when absent. */
export function when(iso) {
  if (!iso) return "–";
  return String(iso).replace("T", " ").replace(/\.\d+Z$/, "").replace(/Z$/, "") + " UTC";
}

export function stateBadge(state) {
  return h("span", { class: "state state-" + String(state).replace(/[^a-z]/g, "") }, String(state));
}

/** A definition list from [[label, value], ...]; value may be a node. */
export function kv(pairs) {
  const dl = h("dl", { class: "kv" });
  for (const [k, v] of pairs) {
    if (v === undefined) continue;
    dl.appendChild(h("dt", null, k));
    dl.appendChild(h("dd", null, v instanceof Node ? v : v === null ? "–" : String(v)));
  }
  return dl;
}

/** A table from column specs [{label, num?, get(row) -> string|Node}] and rows. */
export function table(columns, rows, rowAttrs) {
  const head = h("tr", null, columns.map((c) => h("th", { class: c.num ? "num" : c.wrap ? "wrap" : null }, c.label)));
  const body = h("tbody");
  for (const r of rows) {
    const tr = h("tr", rowAttrs ? rowAttrs(r) : null);
    for (const c of columns) {
      const v = c.get(r);
      tr.appendChild(h("td", { class: c.num ? "num" : c.wrap ? "wrap" : null }, v instanceof Node ? v : v === null || v === undefined ? "–" : String(v)));
    }
    body.appendChild(tr);
  }
  return h("table", null, h("thead", null, head), body);
}

export function errorBox(err) {
  return h("div", { class: "error-box", role: "alert" }, describeError(err));
}

/** A readable message for an Error or a problem+json (ApiError). */
export function describeError(err) {
  if (err && err.problem) {
    const p = err.problem;
    const lines = [(p.title || "Error") + " (" + (p.status || err.status) + ")", p.detail || ""];
    for (const e of p.errors || []) lines.push((e.pointer ?? e.parameter ?? e.header ?? "") + ": " + e.detail);
    return lines.filter(Boolean).join("\n");
  }
  return String(err && err.message ? err.message : err);
}

/** A button group; onPick(value) when one is clicked; the picked one gets class "selected". */
export function choice(options, current, onPick, attrs) {
  const box = h("span", Object.assign({ class: "row", role: "group" }, attrs || {}));
  for (const o of options) {
    const b = h("button", { type: "button", class: o.value === current ? "selected" : null, dataset: { value: o.value } }, o.label);
    b.addEventListener("click", () => {
      for (const x of box.querySelectorAll("button")) x.classList.toggle("selected", x === b);
      onPick(o.value);
    });
    box.appendChild(b);
  }
  return box;
}
