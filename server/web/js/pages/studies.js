// Studies: the list (GET /v1/studies) with state and a live progress bar, search by name
// (?name=, server-side) and pagination through the API's page tokens. The page polls its own
// page of the list once a second while it is open, so new studies appear and running ones
// advance without a reload.
import { api, qs } from "../api.js";
import { h, replace, stateBadge, when, pct, errorBox } from "../dom.js";

const PAGE_SIZE = 20;
const POLL_MS = 1000;

export function progressCell(progress) {
  const total = progress.total || 0;
  const done = progress.done || 0;
  const bar = h("progress", { max: Math.max(total, 1), value: done, "aria-label": "runs done" });
  bar.value = done;
  const label = h("span", { class: "progress-label" }, progressText(progress));
  return h("span", { class: "progress-cell" }, bar, label);
}

export function progressText(progress) {
  const total = progress.total || 0, done = progress.done || 0, failed = progress.failed || 0;
  return pct(done, total) + " % · " + done + "/" + total + (failed ? " · " + failed + " failed" : "");
}

export function updateProgress(cell, progress) {
  const bar = cell.querySelector("progress");
  bar.max = Math.max(progress.total || 0, 1);
  bar.value = progress.done || 0;
  cell.querySelector(".progress-label").textContent = progressText(progress);
}

export async function render(main, params, query, alive) {
  let name = query.get("name") || "";
  let pageToken = query.get("page_token") || "";
  // The trail of earlier page tokens, for "Previous" (in the hash, so Back works too).
  let trail = (query.get("trail") || "").split(",").filter(Boolean);
  const root = h("div");
  main.appendChild(root);

  const search = h("input", { type: "search", placeholder: "Search by name", value: name, "aria-label": "search studies by name", id: "study-search" });
  let debounce = null;
  search.addEventListener("input", () => {
    clearTimeout(debounce);
    debounce = setTimeout(() => {
      // Filter in place (the field keeps the focus); the address follows without a reload.
      name = search.value.trim();
      pageToken = "";
      trail = [];
      history.replaceState(null, "", "#/studies" + qs({ name }));
      refresh();
    }, 300);
  });
  const tbody = h("tbody");
  const table = h(
    "table",
    { id: "studies-table" },
    h("thead", null, h("tr", null, h("th", null, "Name"), h("th", null, "State"), h("th", null, "Progress"), h("th", null, "Created"), h("th", null, "Finished"), h("th", null, "Id"))),
    tbody,
  );
  const pager = h("div", { class: "pager" });
  const status = h("div");
  root.appendChild(
    h(
      "div",
      { class: "card" },
      h("div", { class: "row" }, h("h1", null, "Studies"), h("span", { class: "spacer" }), search, h("a", { class: "button", href: "#/submit" }, "Submit a study…")),
      status,
      h("div", { class: "table-scroll" }, table),
      pager,
    ),
  );

  const rows = new Map(); // id -> {tr, state, progressCell}
  function rowFor(s) {
    const progress = s.progress || {};
    const cell = progressCell(progress);
    const stateTd = h("td", null, stateBadge(s.state));
    const finishedTd = h("td", { class: "muted" }, when(s.finished_at));
    const tr = h(
      "tr",
      { dataset: { id: s.id, state: s.state } },
      h("td", { class: "wrap" }, h("a", { href: "#/studies/" + encodeURIComponent(s.id), class: "study-name" }, s.name)),
      stateTd,
      h("td", null, cell),
      h("td", { class: "muted" }, when(s.created_at)),
      finishedTd,
      h("td", { class: "mono muted" }, s.id),
    );
    return { tr, cell, stateTd, finishedTd, state: s.state };
  }

  let timer = null;
  let stopped = false;
  async function refresh() {
    let page;
    try {
      page = await api.get("/v1/studies" + qs({ page_size: PAGE_SIZE, page_token: pageToken, name }));
    } catch (err) {
      replace(status, errorBox(err));
      return;
    }
    if (!alive()) return;
    replace(status);
    const seen = new Set();
    let i = 0;
    for (const s of page.studies) {
      seen.add(s.id);
      let r = rows.get(s.id);
      if (!r) {
        r = rowFor(s);
        rows.set(s.id, r);
      } else {
        updateProgress(r.cell, s.progress || {});
        if (r.state !== s.state) {
          replace(r.stateTd, stateBadge(s.state));
          r.tr.dataset.state = s.state;
          r.state = s.state;
        }
        r.finishedTd.textContent = when(s.finished_at);
      }
      // Keep the server's order (ids sort in creation order).
      if (tbody.children[i] !== r.tr) tbody.insertBefore(r.tr, tbody.children[i] || null);
      i++;
    }
    for (const [id, r] of rows) {
      if (!seen.has(id)) {
        r.tr.remove();
        rows.delete(id);
      }
    }
    if (!page.studies.length) {
      replace(status, h("p", { class: "notice" }, name ? "No study's name contains “" + name + "”." : "No studies yet. Submit one, or run `stickslip submit SPEC --server URL`."));
    }
    replace(pager);
    if (pageToken) {
      const prev = trail.slice(0, -1);
      pager.appendChild(h("a", { class: "button", href: "#/studies" + qs({ name, page_token: trail[trail.length - 1] || "", trail: prev.join(",") }) }, "‹ Previous"));
      pager.appendChild(h("a", { class: "button", href: "#/studies" + qs({ name }) }, "First"));
    }
    if (page.next_page_token) {
      pager.appendChild(h("a", { class: "button", id: "next-page", href: "#/studies" + qs({ name, page_token: page.next_page_token, trail: [...trail, pageToken].join(",") }) }, "Next ›"));
    }
  }

  async function loop() {
    if (stopped) return;
    if (document.visibilityState === "visible") await refresh();
    if (!stopped) timer = setTimeout(loop, POLL_MS);
  }
  await loop();
  document.body.dataset.page = "studies";
  return () => {
    stopped = true;
    clearTimeout(timer);
    clearTimeout(debounce);
  };
}
