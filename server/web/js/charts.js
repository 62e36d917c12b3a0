// Charts with uPlot 1.6.32 (vendored, the global `uPlot` of uPlot.iife.min.js): lines with
// hover values (uPlot's live legend), heat maps with discrete cells, and bars with confidence
// intervals. Every chart of the current page is registered in window.stickslip.charts[name], so
// the browser tests read the chart library's own data (u.data, u.series), never pixels.
import { h, num } from "./dom.js";

/* global uPlot */

const PALETTE = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];

// A friction model takes the palette colour of its position in the registry (models.js), so it
// has the same colour on every chart; any other series takes the colour of its own position.
let modelOrder = [];
export function setModelOrder(models) {
  modelOrder = models || [];
}

export function colorOf(name, i) {
  const k = modelOrder.indexOf(name);
  return PALETTE[(k >= 0 ? k : i) % PALETTE.length];
}

const registry = (window.stickslip = window.stickslip || {}).charts = {};

/** Destroys every registered chart (the router calls it when the page changes). */
export function destroyCharts() {
  for (const [name, u] of Object.entries(registry)) {
    try {
      if (u._resize) u._resize.disconnect();
      u.destroy();
    } catch (_) {
      /* already gone */
    }
    delete registry[name];
  }
}

function register(name, u, box) {
  if (registry[name]) {
    try {
      registry[name].destroy();
    } catch (_) {
      /* ignore */
    }
  }
  registry[name] = u;
  // Follow the container's width.
  const ro = new ResizeObserver(() => {
    const w = Math.max(240, Math.floor(box.clientWidth));
    if (Math.abs(w - u.width) > 2) u.setSize({ width: w, height: u.height });
  });
  ro.observe(box);
  u._resize = ro;
  return u;
}

function frame(container, title) {
  const box = h("div", { class: "chart-wrap" });
  if (title) container.appendChild(h("div", { class: "chart-title" }, title));
  container.appendChild(box);
  return box;
}

function widthOf(box) {
  return Math.max(240, Math.floor(box.clientWidth || box.parentElement.clientWidth || 600));
}

/**
 * A line chart: x ascending, one series per entry ({label, values, color?, dash?, points?,
 * width?}); null values are gaps. Hovering shows every series' value at the cursor (legend).
 * opts: {name, title, xLabel, yLabel, height, logX, sync, points, onZoom(min, max)}
 */
/** An axis label: "" for the ticks uPlot leaves unlabelled (null, e.g. on log axes). */
const tick = (v) => (v === null || v === undefined ? "" : num(v, 6));

export function lineChart(container, opts) {
  const box = frame(container, opts.title);
  const fmt = (u, v) => num(v);
  const series = [{ label: opts.xLabel || "x", value: fmt }];
  opts.series.forEach((s, i) => {
    series.push({
      label: s.label,
      stroke: s.color || colorOf(s.label, i),
      width: s.width || 1.5,
      dash: s.dash,
      spanGaps: false,
      // Markers only where they can be told apart (a few hundred points at most).
      points: { show: (s.points !== undefined ? s.points : !!opts.points) && opts.x.length <= 300, size: 5 },
      value: fmt,
    });
  });
  const hooks = {};
  if (opts.onZoom) {
    hooks.setScale = [
      (u, key) => {
        if (key === "x" && u._ready) opts.onZoom(u.scales.x.min, u.scales.x.max);
      },
    ];
  }
  const u = new uPlot(
    {
      width: widthOf(box),
      height: opts.height || 280,
      scales: { x: { time: false, distr: opts.logX ? 3 : 1 } },
      axes: [
        { label: opts.xLabel, values: (u, splits) => splits.map(tick) },
        { label: opts.yLabel, values: (u, splits) => splits.map(tick), size: 60 },
      ],
      series,
      cursor: opts.sync ? { sync: { key: opts.sync, setSeries: true } } : {},
      legend: { live: true },
      hooks,
    },
    [opts.x, ...opts.series.map((s) => s.values)],
    box,
  );
  u._ready = true;
  return register(opts.name, u, box);
}

// A perceptually ordered colour scale (viridis, 9 stops).
const VIRIDIS = ["#440154", "#472d7b", "#3b528b", "#2c728e", "#21918c", "#28ae80", "#5ec962", "#addc30", "#fde725"];

function hexToRgb(c) {
  return [1, 3, 5].map((i) => parseInt(c.slice(i, i + 2), 16));
}

/** "rgb(r,g,b)" -> [r, g, b]. */
function rgbOf(rgb) {
  return rgb.slice(4, -1).split(",").map(Number);
}

export function colorScale(t) {
  if (!Number.isFinite(t)) return "#cccccc";
  const x = Math.min(1, Math.max(0, t)) * (VIRIDIS.length - 1);
  const i = Math.min(VIRIDIS.length - 2, Math.floor(x));
  const f = x - i;
  const a = hexToRgb(VIRIDIS[i]), b = hexToRgb(VIRIDIS[i + 1]);
  return "rgb(" + a.map((v, k) => Math.round(v + f * (b[k] - v))).join(",") + ")";
}

/** The labels of an axis: its categories, or its numeric values formatted. Both kinds are
 * drawn as equal bands (a grid's values are often uneven or logarithmic). */
function labelsOf(axis) {
  return axis.categories ? axis.categories.slice() : axis.values.map((v) => num(v, 4));
}

function axisOpts(axis, side) {
  const labels = labelsOf(axis);
  // At most about 12 labels: every k-th band.
  const step = Math.max(1, Math.ceil(labels.length / 12));
  const shown = labels.map((_, i) => i).filter((i) => i % step === 0);
  const longest = Math.max(...labels.map((l) => l.length));
  return {
    label: axis.label,
    side,
    splits: () => shown,
    values: () => shown.map((i) => labels[i]),
    size: side === 3 ? Math.min(160, 30 + 7 * longest) : 50,
    gap: 4,
    grid: { show: false },
  };
}

/**
 * A heat map of discrete cells: z[yi][xi] (null: no value; states[yi][xi] names why).
 * x, y: {label, categories: [names]} or {label, values: [ascending numbers]}: one band of equal
 * size per category or value.
 * Hovering a cell shows its coordinates and value. opts: {name, title, zLabel, height, x, y, z, states}
 */
export function heatmap(container, opts) {
  const box = frame(container, opts.title);
  const bands = (n) => Array.from({ length: n }, (_, i) => [i - 0.5, i + 0.5]);
  const xl = labelsOf(opts.x), yl = labelsOf(opts.y);
  const xe = bands(xl.length), ye = bands(yl.length);
  const finite = opts.z.flat().filter((v) => Number.isFinite(v));
  const zmin = finite.length ? Math.min(...finite) : 0;
  const zmax = finite.length ? Math.max(...finite) : 1;
  const norm = (v) => (zmax > zmin ? (v - zmin) / (zmax - zmin) : 0.5);
  const tip = h("div", { class: "tooltip hidden" });
  const xName = (i) => xl[i];
  const yName = (j) => yl[j];

  // The cells as an image of nx x ny pixels (one per cell, colours from a lookup table), drawn
  // scaled onto the plot: 50,000 cells cost one drawImage instead of 50,000 fillRect calls.
  const nx = xe.length, ny = ye.length;
  const image = document.createElement("canvas");
  image.width = nx;
  image.height = ny;
  {
    const ictx = image.getContext("2d");
    const px = ictx.createImageData(nx, ny);
    const lut = Array.from({ length: 256 }, (_, k) => rgbOf(colorScale(k / 255)));
    for (let j = 0; j < ny; j++) {
      for (let i = 0; i < nx; i++) {
        const v = opts.z[j][i];
        const o = 4 * ((ny - 1 - j) * nx + i); // row 0 of the image is the top band
        const c = Number.isFinite(v) ? lut[Math.round(norm(v) * 255)] : [208, 211, 217];
        px.data[o] = c[0];
        px.data[o + 1] = c[1];
        px.data[o + 2] = c[2];
        px.data[o + 3] = 255;
      }
    }
    ictx.putImageData(px, 0, 0);
  }

  function drawCells(u) {
    const ctx = u.ctx;
    const x0 = u.valToPos(xe[0][0], "x", true), x1 = u.valToPos(xe[nx - 1][1], "x", true);
    const y0 = u.valToPos(ye[ny - 1][1], "y", true), y1 = u.valToPos(ye[0][0], "y", true);
    ctx.save();
    ctx.beginPath();
    ctx.rect(u.bbox.left, u.bbox.top, u.bbox.width, u.bbox.height);
    ctx.clip();
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(image, x0, y0, x1 - x0, y1 - y0);
    // Cells wide enough to be seen one by one get a border, and missing ones a cross.
    const cw = (x1 - x0) / nx, ch = (y1 - y0) / ny;
    if (cw >= 6 && ch >= 6) {
      ctx.strokeStyle = "rgba(255,255,255,0.9)";
      ctx.lineWidth = 1;
      ctx.beginPath();
      for (let i = 0; i <= nx; i++) {
        ctx.moveTo(x0 + i * cw, y0);
        ctx.lineTo(x0 + i * cw, y1);
      }
      for (let j = 0; j <= ny; j++) {
        ctx.moveTo(x0, y0 + j * ch);
        ctx.lineTo(x1, y0 + j * ch);
      }
      ctx.stroke();
      ctx.strokeStyle = "#8a8f99";
      ctx.beginPath();
      for (let j = 0; j < ny; j++) {
        for (let i = 0; i < nx; i++) {
          if (Number.isFinite(opts.z[j][i])) continue;
          const cx = x0 + i * cw, cy = y0 + (ny - 1 - j) * ch;
          ctx.moveTo(cx + 3, cy + 3);
          ctx.lineTo(cx + cw - 3, cy + ch - 3);
        }
      }
      ctx.stroke();
    }
    ctx.restore();
  }

  function cellAt(u) {
    const { left, top } = u.cursor;
    if (left === undefined || left < 0 || top < 0) return null;
    const xv = u.posToVal(left, "x"), yv = u.posToVal(top, "y");
    const i = xe.findIndex(([a, b]) => xv >= a && xv < b);
    const j = ye.findIndex(([a, b]) => yv >= a && yv < b);
    return i < 0 || j < 0 ? null : [i, j];
  }

  const u = new uPlot(
    {
      width: widthOf(box),
      height: opts.height || 300,
      scales: {
        x: { time: false, range: [xe[0][0], xe[xe.length - 1][1]] },
        y: { range: [ye[0][0], ye[ye.length - 1][1]] },
      },
      axes: [axisOpts(opts.x, 2), axisOpts(opts.y, 3)],
      series: [{ label: opts.x.label }, { label: opts.zLabel, stroke: "transparent", points: { show: false } }],
      legend: { show: false },
      cursor: { points: { show: false }, drag: { x: false, y: false } },
      hooks: {
        drawClear: [drawCells],
        setCursor: [
          (u) => {
            const c = cellAt(u);
            if (!c) return tip.classList.add("hidden");
            const [i, j] = c;
            const v = opts.z[j][i];
            const state = opts.states && opts.states[j][i];
            tip.textContent =
              opts.x.label + " = " + xName(i) + "\n" + opts.y.label + " = " + yName(j) + "\n" + opts.zLabel + " = " +
              (Number.isFinite(v) ? num(v) : state || "no value");
            tip.classList.remove("hidden");
            tip.style.left = u.over.offsetLeft + u.cursor.left + 12 + "px";
            tip.style.top = u.over.offsetTop + u.cursor.top + 12 + "px";
          },
        ],
      },
    },
    [[xe[0][0], xe[xe.length - 1][1]], [null, null]],
    box,
  );
  box.appendChild(tip);
  // The cells as the chart draws them, for readers (and the browser tests).
  u.stickslipCells = { x: opts.x, y: opts.y, z: opts.z, states: opts.states };
  container.appendChild(colorbar(zmin, zmax, opts.zLabel));
  return register(opts.name, u, box);
}

function colorbar(lo, hi, label) {
  const c = h("canvas", { width: 200, height: 12 });
  const ctx = c.getContext("2d");
  for (let x = 0; x < 200; x++) {
    ctx.fillStyle = colorScale(x / 199);
    ctx.fillRect(x, 0, 1, 12);
  }
  return h("div", { class: "colorbar" }, num(lo), c, num(hi), h("span", { class: "muted" }, label), h("span", { class: "muted" }, "· grey, crossed: failed or missing"));
}

/**
 * Grouped bars over categories with confidence intervals as whiskers.
 * opts: {name, title, categories, yLabel, height, series: [{label, values, lo, hi, color}]}
 * Hovering shows each series' value and interval in the legend.
 */
export function barsCI(container, opts) {
  const box = frame(container, opts.title);
  const n = opts.series.length;
  const size = n === 1 ? 0.6 : 0.8 / n;
  const x = opts.categories.map((_, i) => i);
  const series = [{ label: "parameter", value: (u, v) => (v === null ? "–" : opts.categories[v]) }];
  opts.series.forEach((s, k) => {
    const align = n === 1 ? 0 : k === 0 ? -1 : 1;
    series.push({
      label: s.label,
      stroke: s.color || PALETTE[k],
      fill: (s.color || PALETTE[k]) + "aa",
      width: 1,
      paths: uPlot.paths.bars({ size: [size, 100], align }),
      points: { show: false },
      value: (u, v, si, idx) => {
        if (idx === null || idx === undefined) return "–";
        const lo = s.lo ? s.lo[idx] : null, hi = s.hi ? s.hi[idx] : null;
        return num(v, 3) + (lo !== null && hi !== null && lo !== undefined ? " [" + num(lo, 3) + ", " + num(hi, 3) + "]" : "");
      },
    });
  });
  function whiskers(u) {
    const ctx = u.ctx;
    const colW = u.valToPos(1, "x", true) - u.valToPos(0, "x", true);
    ctx.save();
    opts.series.forEach((s, k) => {
      if (!s.lo || !s.hi) return;
      const align = n === 1 ? 0 : k === 0 ? -1 : 1;
      const bw = size * colW;
      const off = align === 0 ? 0 : (align * bw) / 2;
      ctx.strokeStyle = "#222";
      ctx.lineWidth = 1.5 * devicePixelRatio;
      for (let i = 0; i < x.length; i++) {
        const lo = s.lo[i], hi = s.hi[i];
        if (!Number.isFinite(lo) || !Number.isFinite(hi)) continue;
        const cx = u.valToPos(i, "x", true) + off;
        const y0 = u.valToPos(lo, "y", true), y1 = u.valToPos(hi, "y", true);
        const cap = Math.max(3, bw * 0.15);
        ctx.beginPath();
        ctx.moveTo(cx, y0);
        ctx.lineTo(cx, y1);
        ctx.moveTo(cx - cap, y0);
        ctx.lineTo(cx + cap, y0);
        ctx.moveTo(cx - cap, y1);
        ctx.lineTo(cx + cap, y1);
        ctx.stroke();
      }
    });
    ctx.restore();
  }
  const all = opts.series.flatMap((s) => [...s.values, ...(s.lo || []), ...(s.hi || [])]).filter(Number.isFinite);
  const ymin = Math.min(0, ...all), ymax = Math.max(0, ...all);
  const pad = (ymax - ymin || 1) * 0.05;
  const u = new uPlot(
    {
      width: widthOf(box),
      height: opts.height || 260,
      scales: { x: { time: false, range: [-0.5, x.length - 0.5] }, y: { range: [ymin - (ymin < 0 ? pad : 0), ymax + pad] } },
      axes: [
        { splits: () => x, values: () => opts.categories.slice(), grid: { show: false } },
        { label: opts.yLabel, values: (u, s) => s.map((v) => num(v, 3)), size: 60 },
      ],
      series,
      legend: { live: true },
      cursor: { points: { show: false }, drag: { x: false, y: false } },
      hooks: { draw: [whiskers] },
    },
    [x, ...opts.series.map((s) => s.values)],
    box,
  );
  return register(opts.name, u, box);
}
