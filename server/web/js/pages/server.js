// Server: GET /healthz and the /metrics figures that matter (Prometheus text, the same scrape a
// monitoring system reads): the queue, runs per second (the rate of stickslip_runs_total between
// two scrapes, drawn over the time this page is open) and errors (failed runs, studies and
// diagnoses, 5xx answers).
import { api } from "../api.js";
import { h, replace, num, errorBox } from "../dom.js";
import { lineChart } from "../charts.js";

const POLL_MS = 2000;

/** Prometheus text exposition -> {"name{labels}": value}. */
export function parseMetrics(text) {
  const out = {};
  for (const line of text.split("\n")) {
    if (!line || line.startsWith("#")) continue;
    const m = line.match(/^([a-zA-Z_:][a-zA-Z0-9_:]*(?:\{[^}]*\})?)\s+(\S+)/);
    if (m) out[m[1]] = Number(m[2]);
  }
  return out;
}

const sum = (m, prefix) => Object.entries(m).filter(([k]) => k.startsWith(prefix)).reduce((a, [, v]) => a + v, 0);

function metric(label, value, id, bad) {
  return h("div", { class: "metric" + (bad ? " bad" : ""), id }, h("div", { class: "value" }, value), h("div", { class: "label" }, label));
}

export async function render(main, params, query, alive) {
  const root = h("div");
  main.appendChild(root);
  const health = h("div");
  const figures = h("div", { id: "server-metrics" });
  const chartBox = h("div", { class: "chart", id: "runs-rate" });
  root.appendChild(h("div", { class: "card" }, h("h1", null, "Server"), health, figures));
  root.appendChild(h("div", { class: "card" }, h("h2", null, "Runs per second since this page opened"), chartBox));
  const times = [], rates = [];
  let prev = null, chart = null, stopped = false, timer = null;

  async function refresh() {
    try {
      const hz = await api.get("/healthz");
      replace(health, h("p", { id: "health" }, "Health: ", h("span", { class: "state state-succeeded" }, hz.status)));
    } catch (err) {
      replace(health, h("p", { id: "health" }, "Health: ", h("span", { class: "state state-failed" }, "unhealthy")), errorBox(err));
    }
    let m;
    try {
      m = parseMetrics(await api.text("/metrics"));
    } catch (err) {
      replace(figures, errorBox(err));
      return;
    }
    if (!alive()) return;
    const now = Date.now() / 1000;
    const runs = sum(m, "stickslip_runs_total");
    let rate = null;
    if (prev) rate = (runs - prev.runs) / Math.max(1e-3, now - prev.t);
    prev = { runs, t: now };
    const failedRuns = (m['stickslip_runs_total{status="diverged"}'] || 0) + (m['stickslip_runs_total{status="invalid"}'] || 0);
    const e5 = m['stickslip_http_responses_total{class="5xx"}'] || 0;
    const e4 = m['stickslip_http_responses_total{class="4xx"}'] || 0;
    replace(
      figures,
      h("h3", null, "Queue"),
      metric("studies queued", m.stickslip_queue_depth ?? "–", "m-queue"),
      metric("studies running", m['stickslip_studies{state="running"}'] ?? "–", "m-running"),
      metric("diagnoses queued / running", (m['stickslip_diagnoses{state="queued"}'] ?? "–") + " / " + (m['stickslip_diagnoses{state="running"}'] ?? "–"), "m-diag-queue"),
      h("h3", null, "Throughput"),
      metric("runs per second (last " + POLL_MS / 1000 + " s)", rate === null ? "…" : num(rate, 3), "m-rate"),
      metric("runs stored", runs, "m-runs"),
      metric("mean run wall time [s]", m.stickslip_run_duration_seconds_count ? num(m.stickslip_run_duration_seconds_sum / m.stickslip_run_duration_seconds_count, 3) : "–", "m-walltime"),
      h("h3", null, "Errors"),
      metric("failed runs (diverged, invalid)", failedRuns, "m-failed-runs", failedRuns > 0),
      metric("failed studies / diagnoses", (m['stickslip_studies{state="failed"}'] || 0) + " / " + (m['stickslip_diagnoses{state="failed"}'] || 0), "m-failed-jobs", (m['stickslip_studies{state="failed"}'] || 0) + (m['stickslip_diagnoses{state="failed"}'] || 0) > 0),
      metric("5xx answers since start", e5, "m-5xx", e5 > 0),
      metric("4xx answers since start", e4, "m-4xx"),
      h("p", { class: "muted small" }, "From ", h("a", { href: "/metrics" }, "/metrics"), " (Prometheus text format), read every " + POLL_MS / 1000 + " s."),
    );
    if (rate !== null) {
      times.push(now);
      rates.push(rate);
      if (times.length > 900) {
        times.shift();
        rates.shift();
      }
      const x = times.map((t) => t - times[0]);
      if (!chart) chart = lineChart(chartBox, { name: "runs-rate", xLabel: "seconds since the page opened", yLabel: "runs/s", x, height: 200, series: [{ label: "runs/s", values: rates.slice(), color: "#2458c6" }] });
      else chart.setData([x, rates.slice()]);
    }
  }
  async function loop() {
    if (stopped) return;
    if (document.visibilityState === "visible") await refresh();
    if (!stopped) timer = setTimeout(loop, POLL_MS);
  }
  await loop();
  document.body.dataset.page = "server";
  return () => {
    stopped = true;
    clearTimeout(timer);
  };
}
