// contactrig console: the plot of R against weight, drawn with uPlot (vendored beside this file: uPlot.iife.min.js,
// MIT, uPlot.LICENSE). Every block (each repeat its own series), the mean ± 1 SEM over the repeats per weight, blocks
// taken in compliance marked (red ✕ on the weight axis, excluded), past sessions of the sample overlaid (grey), and
// after a fit the models' curves (each model's fitted R at the measured weights). Tooltips name the block numbers
// (1-based, as the terminal) and values; drag to zoom, double-click to zoom out. Text from files goes in with
// textContent only.
"use strict";

const Plot = (() => {
  const REPEAT_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"];
  const CURVE_COLOURS = ["#d62728", "#006d2c", "#7f7f7f", "#6a3d9a", "#b15928", "#01665e"];
  // Display units of resistance, largest first (as analysis.resistance.resistance_unit: the largest in which the
  // median magnitude is ≥ 1; mΩ with no value).
  const UNITS = [[1, "Ω"], [1e3, "mΩ"], [1e6, "µΩ"]];

  function unitFor(values) {
    const x = values.filter((v) => v !== null && Number.isFinite(v) && v !== 0).map(Math.abs).sort((a, b) => a - b);
    if (!x.length) return [1e3, "mΩ"];
    const mid = x.length % 2 ? x[(x.length - 1) / 2] : (x[x.length / 2 - 1] + x[x.length / 2]) / 2;
    return UNITS.find(([f]) => mid * f >= 1) || UNITS[UNITS.length - 1];
  }

  // A resistance [Ω] with the SI prefix that shows three significant digits: daq.engine.format_ohm's rule (the
  // terminal's SEM; tests/console check that both give the same text).
  function formatOhm(x) {
    for (const [factor, unit] of [[1, "Ω"], [1e-3, "mΩ"], [1e-6, "µΩ"], [1e-9, "nΩ"]]) {
      if (Math.abs(x) >= factor) return `${g3(x / factor)} ${unit}`;
    }
    return `${g3(x / 1e-12)} pΩ`;
  }

  // Python's "{:.3g}": three significant digits, trailing zeros dropped, exponent form outside 1e-4 … 1e3.
  function g3(v) {
    if (v === 0) return "0";
    const exp = Math.floor(Math.log10(Math.abs(Number(v.toPrecision(3)))));
    if (exp < -4 || exp >= 3) {
      const [m, e] = v.toExponential(2).split("e");
      const mant = m.includes(".") ? m.replace(/0+$/, "").replace(/\.$/, "") : m;
      const n = Number(e);
      return `${mant}e${n < 0 ? "-" : "+"}${String(Math.abs(n)).padStart(2, "0")}`;
    }
    const t = v.toPrecision(3);
    return t.includes(".") ? t.replace(/0+$/, "").replace(/\.$/, "") : t;
  }

  // Per weight: the blocks with a value, their mean and the SEM over the repeats (sd / √k, k ≥ 2).
  function byWeight(blocks) {
    const groups = new Map();
    for (const b of blocks) {
      if (!groups.has(b.weight_kg)) groups.set(b.weight_kg, []);
      groups.get(b.weight_kg).push(b);
    }
    const out = new Map();
    for (const [w, bs] of groups) {
      const v = bs.filter((b) => !b.compliance && b.mean_ohm !== null).map((b) => b.mean_ohm);
      const mean = v.length ? v.reduce((a, c) => a + c, 0) / v.length : null;
      const sem = v.length > 1 ? Math.sqrt(v.reduce((a, c) => a + (c - mean) ** 2, 0) / (v.length - 1) / v.length) : null;
      out.set(w, { blocks: bs, mean, sem, k: v.length });
    }
    return out;
  }

  function fmtKg(w) { return `${Number(w.toPrecision(6))} kg`; }

  // The uPlot data: x = every weight (planned, measured, overlaid, fitted), one y series per repeat, the mean, the
  // past sessions and the fitted curves (null where a series has no value at that weight).
  function build(view) {
    const blocks = view.blocks || [];
    const overlays = view.overlays || [];
    const curves = view.curves || [];
    const weights = new Set([...(view.weights || []), ...blocks.map((b) => b.weight_kg)]);
    for (const o of overlays) for (const p of o.points) weights.add(p.weight_kg);
    for (const c of curves) for (const w of c.weight_kg) weights.add(w);
    const xs = [...weights].sort((a, b) => a - b);
    const at = new Map(xs.map((w, i) => [w, i]));
    const values = [...blocks.map((b) => b.mean_ohm), ...overlays.flatMap((o) => o.points.map((p) => p.mean_ohm)),
      ...curves.flatMap((c) => c.fitted_ohm)];
    const [factor, unit] = unitFor(values);
    const scaled = (v) => (v === null || v === undefined || !Number.isFinite(v) ? null : v * factor);
    const repeats = [...new Set(blocks.map((b) => b.repeat))].sort((a, b) => a - b);
    const groups = byWeight(blocks);
    const data = [xs];
    const series = [{ label: "weight [kg]" }];
    for (const [i, r] of repeats.entries()) {
      const y = xs.map(() => null);
      for (const b of blocks) if (b.repeat === r && !b.compliance && b.mean_ohm !== null) y[at.get(b.weight_kg)] = scaled(b.mean_ohm);
      data.push(y);
      const colour = REPEAT_COLOURS[i % REPEAT_COLOURS.length];
      series.push({ label: `repeat ${r}`, stroke: colour, paths: () => null, points: { show: true, size: 7, fill: colour, stroke: colour } });
    }
    data.push(xs.map((w) => (groups.has(w) ? scaled(groups.get(w).mean) : null)));
    series.push({ label: "mean ± 1 SEM", stroke: "#000", width: 1.5, spanGaps: true, points: { show: true, size: 9, fill: "#fff", stroke: "#000", width: 2 } });
    for (const o of overlays) {
      const y = xs.map(() => null);
      for (const p of o.points) y[at.get(p.weight_kg)] = scaled(p.mean_ohm);
      data.push(y);
      series.push({ label: `past: ${o.path}`, stroke: "#aaa", width: 1, spanGaps: true, points: { show: true, size: 4, fill: "#aaa", stroke: "#aaa" } });
    }
    for (const [i, c] of curves.entries()) {
      const y = xs.map(() => null);
      c.weight_kg.forEach((w, j) => { y[at.get(w)] = scaled(c.fitted_ohm[j]); });
      data.push(y);
      series.push({ label: `fit: ${c.model}`, stroke: CURVE_COLOURS[i % CURVE_COLOURS.length], width: 1.5, dash: [6, 4], spanGaps: true, points: { show: false } });
    }
    const planned = view.weights && view.weights.length ? view.weights : xs;
    return { data, series, xs, groups, factor, unit, planned, curves, overlays, repeats, key: `${repeats.join(",")}|${overlays.length}|${curves.length}` };
  }

  // Error bars (mean ± 1 SEM) and compliance marks, drawn over the series.
  function drawExtras(u, model) {
    const ctx = u.ctx, dpr = devicePixelRatio || 1;
    ctx.save();
    ctx.lineWidth = 1.5 * dpr;
    ctx.strokeStyle = "#000";
    for (const [w, g] of model.groups) {
      if (g.mean === null || g.sem === null) continue;
      const x = u.valToPos(w, "x", true);
      const lo = u.valToPos((g.mean - g.sem) * model.factor, "y", true), hi = u.valToPos((g.mean + g.sem) * model.factor, "y", true);
      ctx.beginPath(); ctx.moveTo(x, lo); ctx.lineTo(x, hi);
      ctx.moveTo(x - 5 * dpr, lo); ctx.lineTo(x + 5 * dpr, lo); ctx.moveTo(x - 5 * dpr, hi); ctx.lineTo(x + 5 * dpr, hi);
      ctx.stroke();
    }
    ctx.strokeStyle = "#c00";
    ctx.lineWidth = 2 * dpr;
    const bottom = u.bbox.top + u.bbox.height - 8 * dpr;
    for (const [w, g] of model.groups) {
      if (!g.blocks.some((b) => b.compliance)) continue;
      const x = u.valToPos(w, "x", true), s = 5 * dpr;
      ctx.beginPath(); ctx.moveTo(x - s, bottom - s); ctx.lineTo(x + s, bottom + s); ctx.moveTo(x + s, bottom - s); ctx.lineTo(x - s, bottom + s); ctx.stroke();
    }
    ctx.restore();
  }

  // The tooltip at the weight under the cursor: every block there (number, run, repeat, R ± SEM as the terminal
  // prints them), the mean ± 1 SEM over the repeats, past sessions and the models' fitted values.
  function tooltipLines(model, idx) {
    const w = model.xs[idx];
    const lines = [`${fmtKg(w)}`];
    const g = model.groups.get(w);
    for (const b of g ? g.blocks : []) {
      const value = b.compliance ? "COMPLIANCE: excluded" : b.mean_ohm === null ? "no valid readings" : `R = ${b.mean_text}${b.sem_text ? ` ± ${b.sem_text}` : ""} (SEM, n = ${b.n})`;
      lines.push(`block ${b.number} (run ${b.run}, repeat ${b.repeat}): ${value}`);
    }
    if (g && g.mean !== null) lines.push(`mean of ${g.k} repeat(s): ${(g.mean * 1e3).toFixed(4)} mΩ${g.sem !== null ? ` ± ${formatOhm(g.sem)} (1 SEM)` : ""}`);
    for (const o of model.overlays) {
      const p = o.points.find((q) => q.weight_kg === w);
      if (p) lines.push(`past ${o.path}: ${(p.mean_ohm * 1e3).toFixed(4)} mΩ`);
    }
    for (const c of model.curves) {
      const j = c.weight_kg.indexOf(w);
      if (j >= 0 && c.fitted_ohm[j] !== null) lines.push(`fit ${c.model}: ${(c.fitted_ohm[j] * 1e3).toFixed(4)} mΩ`);
    }
    return lines;
  }

  function options(holder, model, width) {
    const tip = document.createElement("div");
    tip.className = "plot-tooltip";
    tip.id = "plot-tooltip";
    tip.style.display = "none";
    const pad = (lo, hi) => {
      const span = hi - lo || Math.abs(hi) * 0.1 || 1;
      return [lo - span * 0.06, hi + span * 0.06];
    };
    return {
      width, height: 380,
      scales: {
        x: { time: false, range: (u, lo, hi) => (holder._zoomed ? [lo, hi] : pad(Math.min(lo, ...model.planned), Math.max(hi, ...model.planned))) },
        y: { range: (u, lo, hi) => (lo === null || hi === null ? [0, 1] : pad(lo, hi)) },
      },
      axes: [
        { label: "weight on the piston [kg]", grid: { stroke: "#eee" } },
        { label: `R [${model.unit}]`, size: 70, grid: { stroke: "#eee" } },
      ],
      series: model.series,
      legend: { show: true, live: false },
      cursor: { drag: { x: true, y: true, uni: 30 }, points: { show: false } },
      hooks: {
        init: [(u) => { u.over.append(tip); u.over.addEventListener("dblclick", () => { holder._zoomed = false; }, true); }],
        setSelect: [(u) => { if (u.select.width > 0 || u.select.height > 0) holder._zoomed = true; }],
        draw: [(u) => drawExtras(u, holder._model)],
        setCursor: [(u) => {
          const idx = u.cursor.idx;
          if (idx === null || idx === undefined || u.cursor.left < 0) { tip.style.display = "none"; return; }
          const m = holder._model;
          tip.replaceChildren(...tooltipLines(m, idx).map((t) => { const d = document.createElement("div"); d.textContent = t; return d; }));
          tip.style.display = "block";
          const x = u.valToPos(m.xs[idx], "x");
          tip.style.left = `${Math.min(x + 12, u.over.clientWidth - 260)}px`;
          tip.style.top = `${Math.max(u.cursor.top - 20, 0)}px`;
        }],
      },
    };
  }

  // Draw (or update) the plot in `holder` (an element whose id the tests read: data-points = blocks with a value,
  // data-blocks = every block, data-compliance, data-runs, data-overlaid, data-curves).
  function draw(holder, view) {
    const model = build(view);
    holder._model = model;
    const blocks = view.blocks || [];
    holder.setAttribute("data-points", String(blocks.filter((b) => !b.compliance && b.mean_ohm !== null).length));
    holder.setAttribute("data-blocks", String(blocks.length));
    holder.setAttribute("data-compliance", String(blocks.filter((b) => b.compliance).length));
    holder.setAttribute("data-runs", [...new Set(blocks.map((b) => b.run))].sort((a, b) => a - b).join(","));
    holder.setAttribute("data-overlaid", String((view.overlays || []).length));
    holder.setAttribute("data-curves", String((view.curves || []).length));
    let chart = holder.querySelector(".plot-chart");
    let note = holder.querySelector(".plot-note");
    if (!chart) {
      chart = document.createElement("div");
      chart.className = "plot-chart";
      note = document.createElement("p");
      note.className = "plot-note small";
      holder.append(chart, note);
    }
    const comp = blocks.filter((b) => b.compliance).map((b) => b.number);
    note.textContent = (comp.length ? `✕ compliance in block(s) ${comp.join(", ")}: excluded. ` : "") +
      "Bars: mean ± 1 SEM over the repeats. Drag to zoom, double-click to zoom out; hover for the blocks.";
    const u = holder._uplot;
    if (u && holder._key === model.key && holder._unit === model.unit) {
      u.setData(model.data, !holder._zoomed);
      return;
    }
    if (u) u.destroy();
    holder._zoomed = false;
    const width = Math.max(Math.min((holder.clientWidth || 800) - 16, 1000), 320);
    holder._uplot = new uPlot(options(holder, model, width), model.data, chart);
    holder._key = model.key;
    holder._unit = model.unit;
  }

  // The current block's readings against their index (a small second chart).
  function drawReadings(holder, readings) {
    const vals = (readings || []).map((v) => (v === null ? null : v));
    const [factor, unit] = unitFor(vals);
    const data = [vals.map((_, i) => i + 1), vals.map((v) => (v === null ? null : v * factor))];
    holder.setAttribute("data-readings", String(vals.length));
    if (holder._uplot && holder._unit === unit) { holder._uplot.setData(data); return; }
    if (holder._uplot) holder._uplot.destroy();
    holder._unit = unit;
    holder._uplot = new uPlot({
      width: 360, height: 200, title: "current block",
      scales: { x: { time: false } },
      axes: [{ label: "reading" }, { label: `R [${unit}]`, size: 70 }],
      series: [{ label: "reading" }, { label: "R", stroke: "#888", paths: () => null, points: { show: true, size: 3, fill: "#888" } }],
      legend: { show: false },
    }, data, holder);
  }

  return { draw, drawReadings, formatOhm, tooltipLines, unitFor };
})();
