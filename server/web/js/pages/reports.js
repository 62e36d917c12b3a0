// Nightly reports (GET /v1/reports): the list, and each report's page embedded in a sandboxed
// frame (GET /v1/reports/{date}/index.html, served with a policy that allows no script at all).
import { api, enc } from "../api.js";
import { h, errorBox } from "../dom.js";

export async function render(main, [date], query, alive) {
  const root = h("div");
  main.appendChild(root);
  let list;
  try {
    list = await api.get("/v1/reports");
  } catch (err) {
    root.appendChild(errorBox(err));
    return null;
  }
  if (!alive()) return null;
  const card = h("div", { class: "card" }, h("h1", null, date ? "Nightly report " + date : "Nightly reports"));
  root.appendChild(card);
  if (!list.configured) {
    card.appendChild(h("p", { class: "notice", id: "reports-none" }, "This server serves no reports: start stickslipd with --reports DIR (the --out directory of `stickslip report`)."));
  } else if (!list.reports.length) {
    card.appendChild(h("p", { class: "notice", id: "reports-none" }, "No report yet in the reports directory."));
  }
  const nav = h("div", { class: "row", id: "reports-list" });
  for (const r of list.reports) {
    nav.appendChild(h("a", { class: "button" + (r.date === date ? " selected" : ""), href: "#/reports/" + enc(r.date) }, r.date));
  }
  card.appendChild(nav);
  const shown = date || (list.reports[0] && list.reports[0].date);
  const report = list.reports.find((r) => r.date === shown);
  if (report) {
    card.appendChild(h("p", { class: "muted" }, h("a", { href: report.html }, "open alone"), " · ", h("a", { href: report.summary }, "summary.json")));
    // sandbox="": no script, no forms, no top navigation, even if a report ever had them.
    root.appendChild(h("iframe", { class: "report", src: report.html, sandbox: "", title: "nightly report " + report.date, id: "report-frame" }));
  } else if (date) {
    card.appendChild(errorBox("No report dated " + date));
  }
  document.body.dataset.page = "reports";
  return null;
}
