// Diagnoses: the list (GET /v1/diagnoses) with state, paged with the API's tokens, refreshed
// while one is queued or running.
import { api, qs } from "../api.js";
import { h, replace, stateBadge, when, errorBox } from "../dom.js";

const PAGE_SIZE = 20;
const POLL_MS = 2000;

export async function render(main, params, query, alive) {
  const pageToken = query.get("page_token") || "";
  const trail = (query.get("trail") || "").split(",").filter(Boolean);
  const root = h("div");
  main.appendChild(root);
  const body = h("div");
  root.appendChild(
    h(
      "div",
      { class: "card" },
      h("h1", null, "Diagnoses"),
      h("p", { class: "muted" }, "Measured records calibrated against the friction models, with the named cause. Submit one with ", h("code", null, "stickslip diagnose MANIFEST.json --server URL"), " (or POST /v1/diagnoses)."),
      body,
    ),
  );
  let stopped = false, timer = null;
  async function refresh() {
    let page;
    try {
      page = await api.get("/v1/diagnoses" + qs({ page_size: PAGE_SIZE, page_token: pageToken }));
    } catch (err) {
      replace(body, errorBox(err));
      return false;
    }
    if (!alive()) return false;
    const rows = page.diagnoses.map((d) =>
      h(
        "tr",
        { dataset: { id: d.id, state: d.state } },
        h("td", { class: "wrap" }, h("a", { href: "#/diagnoses/" + encodeURIComponent(d.id) }, d.name)),
        h("td", null, stateBadge(d.state)),
        h("td", { class: "muted" }, when(d.created_at)),
        h("td", { class: "muted" }, when(d.finished_at)),
        h("td", { class: "wrap status-invalid" }, d.error || ""),
        h("td", { class: "mono muted" }, d.id),
      ),
    );
    const pager = h("div", { class: "pager" });
    if (pageToken) pager.appendChild(h("a", { class: "button", href: "#/diagnoses" + qs({ page_token: trail[trail.length - 1] || "", trail: trail.slice(0, -1).join(",") }) }, "‹ Previous"));
    if (page.next_page_token) pager.appendChild(h("a", { class: "button", href: "#/diagnoses" + qs({ page_token: page.next_page_token, trail: [...trail, pageToken].join(",") }) }, "Next ›"));
    replace(
      body,
      rows.length
        ? h("div", { class: "table-scroll" }, h("table", { id: "diagnoses-table" }, h("thead", null, h("tr", null, ["Name", "State", "Created", "Finished", "Error", "Id"].map((x) => h("th", null, x)))), h("tbody", null, rows)))
        : h("p", { class: "notice" }, "No diagnoses yet."),
      pager,
    );
    return page.diagnoses.some((d) => d.state === "queued" || d.state === "running");
  }
  async function loop() {
    const active = await refresh();
    if (!stopped && active) timer = setTimeout(loop, POLL_MS);
  }
  await loop();
  document.body.dataset.page = "diagnoses";
  return () => {
    stopped = true;
    clearTimeout(timer);
  };
}
