// A diagnosis (GET /v1/diagnoses/{id}): its verdict and named cause, the per-model calibration
// table (the seed's Table 2: RMSE per model per run), the candidates, the measured force against
// the base and the extended model per run with the residuals (GET .../traces/{k}: decimated for
// the overview, re-read at full resolution for the zoomed window), the evidence panels with the
// cause's panel marked (the server names it: cause_view), the whole runs held out, and any
// further results the API adds (e.g. validation), shown generically.
import { api, enc, ApiError } from "../api.js";
import { h, replace, stateBadge, when, kv, num, errorBox, table } from "../dom.js";
import { lineChart } from "../charts.js";

const POLL_MS = 2000;
const ACTIVE = new Set(["queued", "running"]);
const OVERVIEW_POINTS = 4000;
// Keys of diagnosis.json this page lays out itself; any other key is shown under "Further results".
const KNOWN = new Set(["dataset", "base_model", "base_note", "base_params", "cause", "best_candidate", "rmse_base_heldout", "rmse_extended_heldout", "gain", "candidates", "evidence", "calibrations", "heldout_runs", "method", "seconds", "evaluations", "verdict"]);

const EVIDENCE_PANELS = [
  { view: "velocity", title: "Residual vs sliding velocity", xLabel: "x' [mm/s]", scale: 1e3, y: "mean residual [N]" },
  { view: "stick_time", title: "Residual vs stick time", xLabel: "time since sliding [s]", scale: 1, y: "mean residual [N]" },
  { view: "position", title: "Residual vs position (trend)", xLabel: "x [mm]", scale: 1e3, y: "mean residual [N]" },
  { view: "x_spectrum", title: "Residual spectrum vs x", xLabel: "wavelength [mm]", scale: 1e3, y: "amplitude [N]", log: true },
  { view: "t_spectrum", title: "Residual spectrum vs t", xLabel: "frequency [Hz]", y: "amplitude [N]", log: true },
  { view: "stage_levels", title: "Stage mean residual vs v_a", xLabel: "v_a [mm/s]", scale: 1e3, y: "mean residual [N]", points: true },
];

export async function render(main, [id], query, alive) {
  const root = h("div");
  main.appendChild(root);
  const base = "/v1/diagnoses/" + enc(id);
  let d;
  try {
    d = await api.get(base);
  } catch (err) {
    root.appendChild(errorBox(err));
    return null;
  }
  if (!alive()) return null;
  const header = h("div", { class: "card" });
  const body = h("div");
  root.append(header, body);

  function showHeader() {
    const actions = h("div", { class: "row" });
    const message = h("div");
    if (ACTIVE.has(d.state)) {
      const b = h("button", { type: "button" }, "Cancel diagnosis");
      b.addEventListener("click", async () => {
        b.disabled = true;
        try {
          await api.post(base + ":cancel");
          replace(message, h("div", { class: "ok-box" }, "Cancelled."));
        } catch (err) {
          if (err instanceof ApiError && (err.status === 401 || err.status === 403)) window.stickslip.askForToken();
          replace(message, errorBox(err));
        }
        b.disabled = false;
      });
      actions.appendChild(b);
    }
    replace(
      header,
      h("div", { class: "row" }, h("h1", { id: "diagnosis-name" }, d.name), h("span", { id: "diagnosis-state" }, stateBadge(d.state))),
      kv([
        ["id", h("code", null, d.id)],
        ["created", when(d.created_at)],
        ["started", when(d.started_at)],
        ["finished", when(d.finished_at)],
        ["error", d.error ? h("span", { class: "status-invalid" }, d.error) : undefined],
      ]),
      actions,
      message,
    );
  }
  showHeader();

  async function showResult() {
    replace(body);
    const r = d.result;
    if (!r) {
      body.appendChild(h("div", { class: "card" }, h("p", { class: "notice" }, ACTIVE.has(d.state) ? "Running… the result appears here when it is done." : "No result.")));
      return;
    }
    body.append(verdictCard(r), calibrationCard(r), candidatesCard(r));
    const tracesCard = h("div", { class: "card", id: "traces-card" }, h("h2", null, "Measured vs model, per run"));
    body.append(tracesCard, evidenceCard(r, d.cause_view), heldoutCard(r), furtherCard(r));
    await traces(tracesCard, base, r, alive);
  }
  await showResult();
  if (!alive()) return null;
  document.body.dataset.page = "diagnosis";
  document.body.dataset.ready = "diagnosis";

  let stopped = false, timer = null;
  async function poll() {
    if (stopped || !ACTIVE.has(d.state)) return;
    try {
      d = await api.get(base);
      if (!alive() || stopped) return;
      showHeader();
      if (!ACTIVE.has(d.state)) await showResult();
    } catch (err) {
      /* keep polling */
    }
    if (!stopped && ACTIVE.has(d.state)) timer = setTimeout(poll, POLL_MS);
  }
  timer = setTimeout(poll, POLL_MS);
  return () => {
    stopped = true;
    clearTimeout(timer);
  };
}

// The base's verdict and, on an inadequate base, whether the named cause's extended model is
// adequate (adequacy.extended_verdict).
function verdictText(r) {
  if (typeof r.verdict !== "string") return JSON.stringify(r.verdict);
  const ext = r.adequacy && r.adequacy.extended_verdict;
  return ext ? r.verdict + " base; with a catalogue effect: " + ext : r.verdict;
}

function verdictCard(r) {
  const none = r.cause === "none";
  const gain = Number.isFinite(r.gain) ? Math.round(r.gain * 1000) / 10 + " %" : "–";
  return h(
    "div",
    { class: "card", id: "verdict" },
    h("h2", null, "Verdict"),
    h("div", { class: "verdict" + (none ? " none" : ""), id: "cause" }, none ? "No cause named: " : "Named cause: ", h("strong", { id: "cause-name" }, r.cause)),
    r.verdict !== undefined ? h("p", { id: "verdict-text" }, verdictText(r)) : null,
    kv([
      ["dataset", r.dataset],
      ["base model", r.base_note ? r.base_model + " (" + r.base_note + ")" : r.base_model],
      ["held-out RMSE, base → extended", num(r.rmse_base_heldout) + " → " + num(r.rmse_extended_heldout) + " N (gain " + gain + ")"],
      ["best candidate", r.best_candidate || "–"],
      ["evaluations", r.evaluations + " in " + num(r.seconds, 3) + " s"],
    ]),
  );
}

function calibrationCard(r) {
  const cals = r.calibrations || [];
  const runs = [];
  for (const c of cals) for (const k of Object.keys(c.rmse_run || {})) if (!runs.includes(k)) runs.push(k);
  const columns = [
    { label: "model", get: (c) => (c.model === r.base_model ? h("strong", null, c.model + " (base)") : c.model) },
    ...runs.map((run) => ({ label: run + " [N]", num: true, get: (c) => num((c.rmse_run || {})[run]) })),
    { label: "fit RMSE [N]", num: true, get: (c) => num(c.rmse_fit) },
    { label: "held-out RMSE [N]", num: true, get: (c) => num(c.rmse_heldout) },
    { label: "AIC", num: true, get: (c) => num(c.aic, 6) },
    { label: "offset [N]", num: true, get: (c) => num(c.offset) },
    { label: "status", get: (c) => c.status },
  ];
  const params = Object.entries(r.base_params || {});
  return h(
    "div",
    { class: "card", id: "calibration" },
    h("h2", null, "Calibration: RMSE per model and run (the seed's Table 2)"),
    h("div", { class: "table-scroll" }, table(columns, cals, (c) => ({ class: c.model === r.base_model ? "best" : null }))),
    h("h3", null, "Parameters of " + r.base_model + " (base-only refit, ± standard error)"),
    table(
      [
        { label: "parameter", get: (p) => p[0] },
        { label: "value (SI)", num: true, get: (p) => num(p[1].value, 5) },
        { label: "± stderr", num: true, get: (p) => num(p[1].stderr, 3) },
      ],
      params,
    ),
  );
}

function candidatesCard(r) {
  const c = r.candidates || [];
  return h(
    "div",
    { class: "card", id: "candidates" },
    h("h2", null, "Candidate extensions"),
    c.length
      ? h(
          "div",
          { class: "table-scroll" },
          table(
            [
              { label: "candidate", get: (x) => (x.id === r.cause ? h("strong", null, x.id + " (cause)") : x.id) },
              { label: "held-out RMSE [N]", num: true, get: (x) => num(x.rmse_heldout) },
              { label: "gain", num: true, get: (x) => num(x.gain, 3) },
              { label: "gain over noise", num: true, get: (x) => num(x.gain_over_noise, 3) },
              { label: "LR", num: true, get: (x) => num(x.lr, 4) },
              { label: "p (Holm)", num: true, get: (x) => num(x.p_holm, 3) },
              { label: "significant", get: (x) => (x.significant ? "yes" : "no") },
              { label: "size", wrap: true, get: (x) => Object.entries(x.params || {}).map(([k, v]) => k + " = " + num(v.value)).join(", ") },
              { label: "status", wrap: true, get: (x) => x.status + (x.at_base_point ? " (at base point)" : "") },
            ],
            c,
            (x) => ({ class: x.id === r.cause ? "best" : null }),
          ),
        )
      : h("p", { class: "notice" }, "No candidate was fitted."),
  );
}

/** One run's charts: measured / base / extended, and the residuals, cursors synced. */
async function traces(card, base, r, alive) {
  let list;
  try {
    list = await api.get(base + "/traces");
  } catch (err) {
    card.appendChild(errorBox(err));
    return;
  }
  if (!alive()) return;
  if (!list.runs.length) {
    card.appendChild(h("p", { class: "notice" }, "No traces stored for this diagnosis (diagnoses made before the server stored them have none)."));
    return;
  }
  const extLabel = r.cause !== "none" ? "+ " + r.cause : r.best_candidate ? "+ " + r.best_candidate + " (not significant)" : "extended";
  const grid = h("div", { class: "grid2" });
  card.appendChild(grid);
  await Promise.all(
    list.runs.map(async (run) => {
      const box = h("div", { class: "trace", id: "trace-" + run.index, dataset: { run: run.run } });
      grid.appendChild(box);
      let t;
      try {
        t = await api.get(base + "/traces/" + run.index + "?max_points=" + OVERVIEW_POINTS);
      } catch (err) {
        box.appendChild(errorBox(err));
        return;
      }
      if (!alive()) return;
      const note = h("div", { class: "muted small" });
      const reset = h("button", { type: "button" }, "Whole run");
      box.append(h("div", { class: "row" }, h("h3", null, run.run), note, reset));
      const chartsBox = h("div");
      box.appendChild(chartsBox);
      const data = (t) => {
        const res = (m) => t.measured.map((v, i) => (v === null || m[i] === null ? null : v - m[i]));
        return {
          force: [t.t, t.measured, t.base, ...(t.extended ? [t.extended] : [])],
          residual: [t.t, res(t.base), ...(t.extended ? [res(t.extended)] : [])],
        };
      };
      const show = (t) => (note.textContent = t.returned + " of " + t.samples + " samples" + (t.decimated ? " (min/max per bucket; zoom in for every sample)" : ""));
      show(t);
      let d0 = data(t);
      let decimated = t.decimated;
      let pending = null;
      const t0 = t.t[0], t1 = t.t[t.t.length - 1];
      const onZoom = (lo, hi) => {
        if (!decimated && !full) return;
        if (lo <= t0 && hi >= t1) return; // the whole run: the overview has it
        clearTimeout(pending);
        pending = setTimeout(async () => {
          try {
            const z = await api.get(base + "/traces/" + run.index + "?max_points=" + OVERVIEW_POINTS + "&t_min=" + lo + "&t_max=" + hi);
            const dz = data(z);
            force.setData(dz.force, false);
            resid.setData(dz.residual, false);
            full = true;
            show(z);
          } catch (_) {
            /* keep the overview */
          }
        }, 250);
      };
      let full = false;
      const force = lineChart(chartsBox, {
        name: "trace-" + run.index,
        title: "drive force F_d [N]",
        xLabel: "t [s]",
        yLabel: "F_d [N]",
        x: d0.force[0],
        sync: "trace-" + run.index,
        height: 240,
        onZoom,
        series: [
          { label: "measured", values: d0.force[1], color: "#8a8f99", width: 1 },
          { label: r.base_model + " (base)", values: d0.force[2], color: "#2458c6" },
          ...(t.extended ? [{ label: extLabel, values: d0.force[3], color: "#c0392b" }] : []),
        ],
      });
      const resid = lineChart(chartsBox, {
        name: "residual-" + run.index,
        title: "residual: measured − model [N]",
        xLabel: "t [s]",
        yLabel: "residual [N]",
        x: d0.residual[0],
        sync: "trace-" + run.index,
        height: 160,
        onZoom,
        series: [
          { label: "base", values: d0.residual[1], color: "#2458c6", width: 1 },
          ...(t.extended ? [{ label: "extended", values: d0.residual[2], color: "#c0392b", width: 1 }] : []),
        ],
      });
      reset.addEventListener("click", () => {
        full = false;
        force.setData(d0.force, true);
        resid.setData(d0.residual, true);
        show(t);
      });
    }),
  );
}

function evidenceCard(r, causeView) {
  const e = r.evidence || {};
  const card = h("div", { class: "card", id: "evidence" }, h("h2", null, "Evidence: residuals of the base (blue) and the extended model (red)"));
  card.appendChild(
    kv([
      ["residual RMS", num(e.residual_rms) + " N"],
      ["lag-1 autocorrelation", num(e.lag1_autocorrelation, 3)],
      ["corr(residual, x' / x / stick time)", [e.corr_velocity, e.corr_position, e.corr_stick_time].map((v) => num(v, 3)).join(" / ")],
      ["trend", num(e.trend_per_m) + " N/m"],
      ["strongest period along x", e.x_spectrum_peak ? num(e.x_spectrum_peak.wavelength) + " m, " + num(e.x_spectrum_peak.amplitude) + " N" : "–"],
      ["strongest frequency", e.t_spectrum_peak ? num(e.t_spectrum_peak.frequency) + " Hz, " + num(e.t_spectrum_peak.amplitude) + " N" : "–"],
      ["extended model shown", e.extended_model || "–"],
    ]),
  );
  const grid = h("div", { class: "grid3" });
  card.appendChild(grid);
  for (const p of EVIDENCE_PANELS) {
    const series = evidenceSeries(e, p);
    const marked = causeView === p.view;
    const box = h("div", { class: "chart" + (marked ? " marked" : ""), id: "evidence-" + p.view, dataset: { view: p.view, marked: marked ? "true" : "false" } });
    grid.appendChild(box);
    if (marked) box.appendChild(h("div", { class: "marked-label" }, "◆ the named cause (" + r.cause + ") acts here"));
    if (!series) {
      box.appendChild(h("p", { class: "notice" }, p.title + ": no data"));
      continue;
    }
    lineChart(box, {
      name: "evidence-" + p.view,
      title: p.title,
      xLabel: p.xLabel,
      yLabel: p.y,
      x: series.x,
      logX: p.log,
      height: 200,
      points: !!p.points,
      series: [
        { label: "base", values: series.base, color: "#2458c6", points: !!p.points },
        { label: "extended", values: series.ext, color: "#c0392b", points: !!p.points },
      ],
    });
  }
  return card;
}

/** x ascending with the base and extended values, for one evidence panel (null: no data). */
function evidenceSeries(e, p) {
  let x = [], b = [], x2 = [];
  const scale = p.scale || 1;
  if (["velocity", "stick_time", "position"].includes(p.view)) {
    const prof = (e.profiles || {})[p.view];
    if (!prof || !prof.center || !prof.center.length) return null;
    x = prof.center;
    b = prof.base;
    x2 = prof.extended;
  } else if (p.view === "x_spectrum") {
    const s = e.x_spectrum || {};
    x = s.wavelength || [];
    b = s.base || [];
    x2 = s.extended || [];
  } else if (p.view === "t_spectrum") {
    const s = e.t_spectrum || {};
    x = (s.period || []).map((v) => (v ? 1 / v : null));
    b = s.base || [];
    x2 = s.extended || [];
  } else {
    const s = e.stage_level_vs_va || [];
    x = s.map((v) => v.va);
    b = s.map((v) => v.mean_residual);
    x2 = s.map((v) => v.mean_residual_extended);
  }
  const rows = x.map((v, i) => [v === null ? null : p.view === "t_spectrum" ? v : v * scale, b[i] ?? null, x2[i] ?? null]).filter((r) => r[0] !== null && (!p.log || r[0] > 0));
  if (!rows.length) return null;
  rows.sort((a, c) => a[0] - c[0]);
  return { x: rows.map((r) => r[0]), base: rows.map((r) => r[1]), ext: rows.map((r) => r[2]) };
}

function heldoutCard(r) {
  const hr = r.heldout_runs;
  const card = h("div", { class: "card", id: "heldout" }, h("h2", null, "Whole runs held out (refit on the others, scored on the run left out)"));
  if (!hr) {
    card.appendChild(h("p", { class: "notice" }, "Not computed (one run, or turned off)."));
    return card;
  }
  card.appendChild(kv([["pooled RMSE, base → extended", num(hr.rmse_base) + " → " + num(hr.rmse_extended) + " N (gain " + num(hr.gain, 3) + ")"]]));
  card.appendChild(
    table(
      [
        { label: "run left out", get: (f) => f.run },
        { label: "v_a [mm/s]", num: true, get: (f) => num(f.va === null ? null : f.va * 1e3) },
        { label: "RMSE base [N]", num: true, get: (f) => num(f.rmse_base) },
        { label: "RMSE extended [N]", num: true, get: (f) => num(f.rmse_extended) },
        { label: "gain", num: true, get: (f) => num(f.gain, 3) },
        { label: "status", wrap: true, get: (f) => f.status },
      ],
      hr.folds || [],
    ),
  );
  return card;
}

/** Any result the page does not lay out itself (e.g. validation results added later). */
function furtherCard(r) {
  const extra = Object.keys(r).filter((k) => !KNOWN.has(k));
  const card = h("div", { class: "card", id: "further" });
  if (!extra.length) {
    card.hidden = true;
    return card;
  }
  card.appendChild(h("h2", null, "Further results"));
  for (const k of extra) card.append(h("h3", { dataset: { key: k } }, k), generic(r[k]));
  return card;
}

function generic(v, depth = 0) {
  if (v === null || typeof v !== "object") return h("span", null, typeof v === "number" ? num(v, 5) : String(v));
  if (Array.isArray(v)) {
    if (v.length && v.every((x) => x && typeof x === "object" && !Array.isArray(x))) {
      const keys = [];
      for (const x of v) for (const k of Object.keys(x)) if (!keys.includes(k)) keys.push(k);
      return h("div", { class: "table-scroll" }, table(keys.map((k) => ({ label: k, get: (x) => (x[k] !== null && typeof x[k] === "object" ? JSON.stringify(x[k]) : typeof x[k] === "number" ? num(x[k], 5) : x[k]) })), v));
    }
    return h("span", null, v.map((x) => (typeof x === "number" ? num(x, 5) : JSON.stringify(x))).join(", "));
  }
  if (depth > 3) return h("code", null, JSON.stringify(v));
  return kv(Object.entries(v).map(([k, x]) => [k, generic(x, depth + 1)]));
}
