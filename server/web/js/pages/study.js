// A study: state and live progress (GET /v1/studies/{id}, polled while it runs), its spec, the
// stick-slip map as line charts (GET .../map: amplitude, mean force and reduction ratio against
// the design's first variable, usually v_a/v_d, one series per model), a heat map for two-axis
// designs (discrete cells; the model is a categorical axis), the runs table paged with the API's
// page tokens (GET .../runs) with a CSV download, and for Sobol / Morris designs the indices as
// bars with their confidence intervals (GET .../indices).
import { api, enc, ApiError } from "../api.js";
import { h, replace, stateBadge, when, kv, num, errorBox, choice, describeError } from "../dom.js";
import { lineChart, heatmap, barsCI, colorOf, setModelOrder } from "../charts.js";
import { frictionModels } from "../models.js";
import { progressCell, updateProgress } from "./studies.js";

const POLL_MS = 1000;
const MAP_REFRESH_MS = 3000;
const RUNS_PAGE = 50;
const ACTIVE = new Set(["queued", "running"]);

export async function render(main, [id], query, alive) {
  const root = h("div");
  main.appendChild(root);
  const base = "/v1/studies/" + enc(id);
  let study;
  try {
    study = await api.get(base);
  } catch (err) {
    root.appendChild(errorBox(err));
    return null;
  }
  if (!alive()) return null;

  // --- header: name, state, progress, times -------------------------------------------------
  const title = h("h1", { id: "study-name" }, study.name);
  const badge = h("span", { id: "study-state" }, stateBadge(study.state));
  const progress = progressCell(study.progress || {});
  progress.querySelector("progress").classList.add("wide");
  const times = h("div");
  const actions = h("div", { class: "row" });
  const message = h("div");
  const header = h("div", { class: "card" }, h("div", { class: "row" }, title, badge), progress, times, actions, message);
  const mapCard = h("div", { class: "card", id: "map-card" });
  const heatCard = h("div", { class: "card", id: "heatmap-card" });
  const indicesCard = h("div", { class: "card", id: "indices-card" });
  const runsCard = h("div", { class: "card", id: "runs-card" });
  const specCard = h("div", { class: "card" });
  root.append(header, mapCard, heatCard, indicesCard, runsCard, specCard);
  heatCard.hidden = true;
  indicesCard.hidden = true;

  function showHeader(s) {
    replace(badge, stateBadge(s.state));
    updateProgress(progress, s.progress || {});
    replace(
      times,
      kv([
        ["id", h("code", null, s.id)],
        ["created", when(s.created_at)],
        ["started", when(s.started_at)],
        ["finished", when(s.finished_at)],
        ["error", s.error ? h("span", { class: "status-invalid" }, s.error) : undefined],
      ]),
    );
    replace(actions);
    if (ACTIVE.has(s.state)) {
      const b = h("button", { type: "button", id: "cancel-study" }, "Cancel study");
      b.addEventListener("click", async () => {
        b.disabled = true;
        try {
          const r = await api.post(base + ":cancel");
          replace(message, h("div", { class: "ok-box" }, "Cancel " + (r.status === 202 ? "requested" : "done") + "."));
        } catch (err) {
          if (err instanceof ApiError && (err.status === 401 || err.status === 403)) window.stickslip.askForToken();
          replace(message, errorBox(err));
        }
        b.disabled = false;
      });
      actions.appendChild(b);
    }
  }
  showHeader(study);

  // --- spec ---------------------------------------------------------------------------------
  const spec = study.spec || {};
  specCard.append(h("details", null, h("summary", null, "Spec"), h("pre", { class: "spec", id: "study-spec" }, JSON.stringify(spec, null, 2))));

  // --- runs table, paged --------------------------------------------------------------------
  const runsState = { trail: [], token: "" };
  const runsBody = h("div");
  const csv = h("a", { class: "button", href: base + "/runs?format=csv", download: id + "-runs.csv", id: "runs-csv" }, "Download CSV");
  runsCard.append(h("div", { class: "row" }, h("h2", null, "Runs"), csv), runsBody);
  async function loadRuns() {
    let page;
    try {
      page = await api.get(base + "/runs?page_size=" + RUNS_PAGE + (runsState.token ? "&page_token=" + enc(runsState.token) : ""));
    } catch (err) {
      replace(runsBody, errorBox(err));
      return;
    }
    replace(runsBody, runsTable(page.runs));
    performance.mark("runs-drawn");
    const pager = h("div", { class: "pager" });
    if (runsState.trail.length) {
      const prev = h("button", { type: "button", id: "runs-prev" }, "‹ Previous");
      prev.addEventListener("click", () => {
        runsState.token = runsState.trail.pop();
        loadRuns();
      });
      pager.appendChild(prev);
    }
    if (page.next_page_token) {
      const next = h("button", { type: "button", id: "runs-next" }, "Next ›");
      next.addEventListener("click", () => {
        runsState.trail.push(runsState.token);
        runsState.token = page.next_page_token;
        loadRuns();
      });
      pager.appendChild(next);
    }
    pager.appendChild(h("span", { class: "muted" }, page.runs.length ? "runs " + page.runs[0].design_index + "–" + page.runs[page.runs.length - 1].design_index + " of " + (study.progress || {}).total : "no runs stored yet"));
    runsBody.appendChild(pager);
  }

  // --- map, heat map, indices ---------------------------------------------------------------
  const view = { stage: null, metric: "amplitude", group: 0, model: null, output: null };
  let map = null;
  // A sampled design (random, LHS, Sobol, Morris) has no grid to draw a map on: every point is
  // its own; its views are the indices and the runs table.
  const sampled = ["random", "lhs", "sobol", "morris"].includes((spec.design || {}).type);
  async function loadMap() {
    if (sampled) {
      replace(mapCard, h("h2", null, "Stick-slip map"), h("p", { class: "notice", id: "no-map" }, "A sampled (" + spec.design.type + ") design has no grid to map: see the indices and the runs table."));
      return;
    }
    try {
      const [columns, models] = await Promise.all([api.get(base + "/map?layout=columns"), frictionModels()]);
      performance.mark("map-fetched");
      setModelOrder(models);
      map = fromColumns(columns);
    } catch (err) {
      replace(mapCard, h("h2", null, "Stick-slip map"), h("p", { class: "notice" }, "No map for this study: " + describeError(err)));
      return;
    }
    if (!alive()) return;
    if (view.stage === null) view.stage = map.stages || 1;
    drawMap();
    performance.mark("map-drawn");
  }
  function drawMap() {
    mapCharts(mapCard, map, view, drawMap);
    heatCard.hidden = !heatmapCharts(heatCard, map, view, drawMap);
  }

  const design = (spec.design || {}).type;
  async function loadIndices() {
    if (design !== "sobol" && design !== "morris") return;
    indicesCard.hidden = false;
    let ind;
    try {
      ind = await api.get(base + "/indices");
    } catch (err) {
      replace(indicesCard, h("h2", null, "Sensitivity indices"), errorBox(err));
      return;
    }
    if (!alive()) return;
    indicesCharts(indicesCard, ind, view);
  }

  await Promise.all([loadRuns(), loadMap(), loadIndices()]);
  if (!alive()) return null;
  // Everything of the first view is drawn (the page-open benchmark waits for this).
  performance.mark("study-ready");
  document.body.dataset.page = "study";
  document.body.dataset.ready = "study";

  // --- live updates while the study runs ----------------------------------------------------
  let stopped = false, timer = null, lastMap = Date.now(), lastDone = (study.progress || {}).done, mapCost = 0;
  async function poll() {
    if (stopped) return;
    if (document.visibilityState === "visible" && ACTIVE.has(study.state)) {
      try {
        const s = await api.get(base);
        if (!alive() || stopped) return;
        const finished = !ACTIVE.has(s.state);
        study = s;
        showHeader(s);
        const done = (s.progress || {}).done;
        // The map of a large study costs the server a read of every run: refresh it at most
        // every 3 s, and never more often than ten times as long as it took to load.
        if (finished || (done !== lastDone && Date.now() - lastMap > Math.max(MAP_REFRESH_MS, 10 * mapCost))) {
          lastMap = Date.now();
          lastDone = done;
          const t0 = performance.now();
          await Promise.all([loadMap(), finished ? loadRuns() : null, finished ? loadIndices() : null]);
          mapCost = performance.now() - t0;
        }
      } catch (err) {
        replace(message, errorBox(err));
      }
    }
    if (!stopped && ACTIVE.has(study.state)) timer = setTimeout(poll, POLL_MS);
  }
  timer = setTimeout(poll, POLL_MS);
  return () => {
    stopped = true;
    clearTimeout(timer);
  };
}

/** The map by columns (GET .../map?layout=columns: a third of the bytes of the row layout
 * for a large study) as the rows the charts read: {key: {name: value}, cells: {model: {state,
 * amplitude: [per stage], mean_force: [per stage], ratio}}}. */
function fromColumns(c) {
  const n = c.key_names.length ? c.keys[c.key_names[0]].length : c.models.length ? c.cells[c.models[0]].state.length : 0;
  const rows = new Array(n);
  for (let i = 0; i < n; i++) {
    const key = {};
    for (const k of c.key_names) key[k] = c.keys[k][i];
    const cells = {};
    for (const m of c.models) {
      const col = c.cells[m];
      if (col.state[i] === null) continue;
      cells[m] = {
        state: col.state[i],
        amplitude: col.amplitude.map((s) => s[i]),
        mean_force: col.mean_force.map((s) => s[i]),
        ratio: col.ratio[i],
      };
    }
    rows[i] = { key, cells };
  }
  return Object.assign({}, c, { rows });
}

// --- the runs table ---------------------------------------------------------------------------

function runsTable(runs) {
  const params = [];
  for (const r of runs) for (const k of Object.keys(r.params || {})) if (k !== "model" && k !== "va_over_vd" && !params.includes(k)) params.push(k);
  const stages = Math.max(0, ...runs.map((r) => (r.stages || []).length));
  const head = ["#", "model", "v_a/v_d", "status", ...params];
  for (let s = 1; s <= stages; s++) head.push("amplitude " + s + " [N]", "mean force " + s + " [N]");
  head.push("wall time [s]");
  const tbody = h("tbody");
  for (const r of runs) {
    const tr = h("tr", { dataset: { index: r.design_index } });
    const cells = [r.design_index, r.model, num(r.va_over_vd), h("span", { class: "status-" + r.status, title: r.error || "" }, r.status), ...params.map((p) => num(r.params[p]))];
    for (let s = 0; s < stages; s++) {
      const st = (r.stages || [])[s] || {};
      cells.push(num(st.amplitude), num(st.mean_force));
    }
    cells.push(num(r.wall_time_s, 3));
    cells.forEach((c, i) => tr.appendChild(h("td", { class: i === 1 || i === 3 ? null : "num" }, c === null || c === undefined ? "–" : c)));
    tbody.appendChild(tr);
  }
  return h("div", { class: "table-scroll" }, h("table", { id: "runs-table" }, h("thead", null, h("tr", null, head.map((x, i) => h("th", { class: i === 1 || i === 3 ? null : "num" }, x)))), tbody));
}

// --- map charts ---------------------------------------------------------------------------

const X_PREFERRED = "va_over_vd";
const LABELS = { va_over_vd: "v_a / v_d [-]" };
const label = (k) => LABELS[k] || k;

function stageButtons(map, view, redraw) {
  const opts = [];
  for (let s = 1; s <= (map.stages || 1); s++) opts.push({ value: s, label: "Stage " + s });
  return choice(opts, view.stage, (v) => {
    view.stage = v;
    redraw();
  });
}

function cellValue(cell, metric, stage) {
  if (!cell || cell.state !== "ok") return null;
  if (metric === "ratio") return cell.ratio ?? null;
  const v = (cell[metric] || [])[stage - 1];
  return v === undefined ? null : v;
}

/** The keys that vary (more than one value), most values first; va_over_vd first on a tie. */
function varying(map) {
  const keys = map.key_names || [];
  const count = (k) => new Set(map.rows.map((r) => r.key[k])).size;
  return keys
    .map((k) => [k, count(k)])
    .filter(([, n]) => n > 1)
    .sort((a, b) => b[1] - a[1] || (b[0] === X_PREFERRED) - (a[0] === X_PREFERRED))
    .map(([k]) => k);
}

/** Rows grouped by the values of every varying key but x (the one with the most values). */
function groups(map) {
  const keys = varying(map);
  const all = map.key_names || [];
  const x = keys[0] || (all.includes(X_PREFERRED) ? X_PREFERRED : all[0]);
  const others = keys.filter((k) => k !== x);
  const byGroup = new Map();
  for (const row of map.rows) {
    const g = others.map((k) => k + " = " + num(row.key[k])).join(", ");
    if (!byGroup.has(g)) byGroup.set(g, []);
    byGroup.get(g).push(row);
  }
  return { x, others, list: [...byGroup.entries()] };
}

function mapCharts(card, map, view, redraw) {
  replace(card);
  card.appendChild(h("div", { class: "row" }, h("h2", null, "Stick-slip map"), stageButtons(map, view, redraw), h("span", { class: "muted small" }, [map.missing ? map.missing + " missing" : "", map.failed ? map.failed + " failed" : ""].filter(Boolean).join(" · "))));
  const g = groups(map);
  if (!g.x) {
    card.appendChild(h("p", { class: "notice" }, "The design has no variable besides the model: see the runs table."));
    return;
  }
  if (g.list.length > 1) {
    const sel = h("select", { "aria-label": "fixed values of the other variables" });
    g.list.forEach(([name], i) => sel.appendChild(h("option", { value: i, selected: i === view.group }, name)));
    sel.addEventListener("change", () => {
      view.group = Number(sel.value);
      redraw();
    });
    card.appendChild(h("p", null, "At ", sel));
  }
  const rows = (g.list[Math.min(view.group, g.list.length - 1)] || [null, []])[1].slice().sort((a, b) => a.key[g.x] - b.key[g.x]);
  const x = rows.map((r) => r.key[g.x]);
  const grid = h("div", { class: "grid3" });
  card.appendChild(grid);
  const charts = [
    ["amplitude", "Stick-slip amplitude, stage " + view.stage + " [N]"],
    ["mean_force", "Mean drive force, stage " + view.stage + " [N]"],
  ];
  if ((map.stages || 1) > 1) charts.push(["ratio", "Reduction ratio: amplitude stage " + map.stages + " / stage 1 [-]"]);
  for (const [metric, title] of charts) {
    const box = h("div", { class: "chart", id: "map-" + metric });
    grid.appendChild(box);
    const series = map.models.map((m, i) => ({ label: m, color: colorOf(m, i), values: rows.map((r) => cellValue(r.cells[m], metric, view.stage)) }));
    if (metric === "ratio" && series.every((s) => s.values.every((v) => v === null))) {
      box.append(h("div", { class: "chart-title" }, title), h("p", { class: "notice" }, "No ratio: stage 1 has no stick-slip (amplitude 0) or no run finished."));
      continue;
    }
    lineChart(box, {
      name: "map-" + metric,
      title,
      xLabel: label(g.x),
      yLabel: metric === "ratio" ? "ratio [-]" : "F [N]",
      x,
      points: true,
      sync: "map",
      height: 260,
      series,
    });
  }
}

/** The heat map of a two-axis design: (model x variable) or (variable x variable, per model).
 * Returns false when the design has another number of axes. */
function heatmapCharts(card, map, view, redraw) {
  const keys = varying(map);
  const models = map.models || [];
  const axes = keys.length + (models.length > 1 ? 1 : 0);
  if (axes !== 2) return false;
  replace(card);
  const metricOpts = [
    { value: "amplitude", label: "amplitude" },
    { value: "mean_force", label: "mean force" },
  ];
  if ((map.stages || 1) > 1) metricOpts.push({ value: "ratio", label: "reduction ratio" });
  card.appendChild(
    h(
      "div",
      { class: "row" },
      h("h2", null, "Heat map"),
      choice(metricOpts, view.metric, (v) => {
        view.metric = v;
        redraw();
      }),
      stageButtons(map, view, redraw),
    ),
  );
  const zLabel = view.metric === "ratio" ? "reduction ratio [-]" : (view.metric === "amplitude" ? "amplitude" : "mean force") + ", stage " + view.stage + " [N]";
  const box = h("div", { class: "chart", id: "heatmap" });
  card.appendChild(box);
  if (keys.length === 1) {
    // The model is a categorical axis: one band per model, one cell per value of the variable.
    const xName = keys[0];
    const xs = [...new Set(map.rows.map((r) => r.key[xName]))].sort((a, b) => a - b);
    const rowAt = new Map(map.rows.map((r) => [r.key[xName], r]));
    const z = models.map((m) => xs.map((x) => cellValue((rowAt.get(x) || { cells: {} }).cells[m], view.metric, view.stage)));
    const states = models.map((m) => xs.map((x) => ((rowAt.get(x) || { cells: {} }).cells[m] || {}).state || "missing"));
    heatmap(box, { name: "heatmap", zLabel, height: 80 + 46 * models.length, x: { label: label(xName), values: xs }, y: { label: "model", categories: models.slice() }, z, states });
  } else {
    const [xName, yName] = keys;
    const model = models[0];
    const xs = [...new Set(map.rows.map((r) => r.key[xName]))].sort((a, b) => a - b);
    const ys = [...new Set(map.rows.map((r) => r.key[yName]))].sort((a, b) => a - b);
    const at = new Map(map.rows.map((r) => [r.key[xName] + "|" + r.key[yName], r]));
    const z = ys.map((y) => xs.map((x) => cellValue((at.get(x + "|" + y) || { cells: {} }).cells[model], view.metric, view.stage)));
    const states = ys.map((y) => xs.map((x) => ((at.get(x + "|" + y) || { cells: {} }).cells[model] || {}).state || "missing"));
    card.appendChild(h("p", { class: "muted small" }, "model: " + model));
    heatmap(box, { name: "heatmap", zLabel, height: 320, x: { label: label(xName), values: xs }, y: { label: label(yName), values: ys }, z, states });
  }
  return true;
}

// --- indices ------------------------------------------------------------------------------

function indicesCharts(card, ind, view) {
  replace(card);
  const outputs = ind.outputs || [];
  if (!view.output || !outputs.some((o) => o.output === view.output)) view.output = outputs.length ? outputs[0].output : null;
  const body = h("div");
  card.append(
    h(
      "div",
      { class: "row" },
      h("h2", null, (ind.method === "sobol" ? "Sobol" : "Morris") + " indices"),
      choice(
        outputs.map((o) => ({ value: o.output, label: o.output })),
        view.output,
        (v) => {
          view.output = v;
          draw();
        },
      ),
      h("span", { class: "muted small" }, Math.round((ind.confidence || 0.95) * 100) + " % bootstrap intervals, " + (ind.resamples || "") + " resamples"),
    ),
    body,
  );
  function draw() {
    replace(body);
    const o = outputs.find((x) => x.output === view.output);
    if (!o) return;
    if (!o.valid) {
      body.appendChild(h("p", { class: "notice" }, "Not computed: " + o.reason + (o.invalid_count ? " (" + o.invalid_count + " design points)" : "")));
      return;
    }
    const rows = o.indices || [];
    const categories = rows.map((r) => r.parameter);
    const box = h("div", { class: "chart", id: "indices-chart" });
    body.appendChild(box);
    const ci = (r, k, i) => (r[k] ? r[k][i] : null);
    if (ind.method === "sobol") {
      barsCI(box, {
        name: "indices",
        title: o.output,
        categories,
        yLabel: "index [-]",
        series: [
          { label: "S1 (first order)", values: rows.map((r) => r.S1), lo: rows.map((r) => ci(r, "S1_ci", 0)), hi: rows.map((r) => ci(r, "S1_ci", 1)), color: "#2458c6" },
          { label: "ST (total)", values: rows.map((r) => r.ST), lo: rows.map((r) => ci(r, "ST_ci", 0)), hi: rows.map((r) => ci(r, "ST_ci", 1)), color: "#e07b22" },
        ],
      });
    } else {
      barsCI(box, {
        name: "indices",
        title: o.output,
        categories,
        yLabel: "elementary effect [output unit]",
        series: [
          { label: "μ*", values: rows.map((r) => r.mu_star), lo: rows.map((r) => ci(r, "mu_star_ci", 0)), hi: rows.map((r) => ci(r, "mu_star_ci", 1)), color: "#2458c6" },
          { label: "σ", values: rows.map((r) => r.sigma), color: "#e07b22" },
        ],
      });
    }
  }
  draw();
}
