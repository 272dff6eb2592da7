// contactrig console: every string from the server goes into the page as text (textContent), never as markup.
"use strict";

const CLIENT = sessionStorage.getItem("contactrig-client") || Math.random().toString(36).slice(2);
sessionStorage.setItem("contactrig-client", CLIENT);
let source = null; // the EventSource of the run page, closed when leaving it

function el(tag, attrs, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "onclick" || k === "onchange" || k === "oninput") node.addEventListener(k.slice(2), v);
    else if (k === "text") node.textContent = String(v);
    else node.setAttribute(k, String(v));
  }
  for (const c of children) node.append(c instanceof Node ? c : document.createTextNode(String(c ?? "")));
  return node;
}

function main(...children) {
  const m = document.getElementById("main");
  m.replaceChildren(...children);
  return m;
}

async function api(path, body) {
  const init = body === undefined ? {} : {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
  };
  const r = await fetch(path, init);
  let data = {};
  try { data = await r.json(); } catch (e) { data = { error: `HTTP ${r.status}` }; }
  data._status = r.status;
  return data;
}

function fmtOhm(x) {
  if (x === null || x === undefined) return "—";
  return (x * 1e3).toFixed(4) + " mΩ";
}

function fmtDuration(s) {
  if (s === null || s === undefined) return "—";
  if (s < 60) return `${Math.round(s)} s`;
  return `${Math.floor(s / 60)} min ${String(Math.round(s % 60)).padStart(2, "0")} s`;
}

// ---- sessions ----------------------------------------------------------------------------------------------
let sortKey = "start";

async function showSessions() {
  const filter = el("input", { id: "filter", placeholder: "sample contains…" });
  const table = el("table", { id: "sessions-table" });
  const runsBox = el("div", { id: "console-runs" });
  main(el("h1", { text: "Sessions" }), runsBox, el("label", {}, "Filter by sample: ", filter), table);
  const runs = await api("/api/runs");
  if ((runs.runs || []).length) runsBox.append(el("h2", { text: "Started from this console" }));
  for (const r of runs.runs || []) {
    runsBox.append(el("p", {}, el("a", { href: `#/run/${encodeURIComponent(r.id)}`, text: `${r.file}: ${r.phase}, ${r.blocks}/${r.blocks_planned} blocks` })));
  }
  const load = async () => {
    const q = new URLSearchParams({ sort: sortKey });
    if (filter.value) q.set("sample", filter.value);
    const data = await api(`/api/sessions?${q}`);
    const cols = [["start", "start"], ["status", "status"], ["blocks", null], ["kind", null], ["sample", "sample"], ["operator", "operator"], ["file", "path"], ["", null]];
    const head = el("tr", {}, ...cols.map(([name, key]) => {
      const th = el("th", { text: name + (key === sortKey ? " ▾" : "") });
      if (key) th.addEventListener("click", () => { sortKey = key; load(); });
      return th;
    }));
    const rows = (data.sessions || []).map((s) => {
      const blocks = s.blocks_done === null ? "" : `${s.blocks_done}/${s.blocks_planned ?? "?"}` + (s.compliant_blocks ? ` (${s.compliant_blocks} compliance)` : "");
      const link = el("a", { href: `#/session/${encodeURIComponent(s.path)}`, text: s.path });
      const action = el("td");
      if (s.status === "aborted" || s.status === "incomplete" || s.status === "failed") {
        action.append(el("button", { class: "resume", onclick: () => resume(s.path, s.kind === "simulated"), text: "Resume" }));
      }
      const status = ["corrupt", "newer"].includes(s.status) ? s.status.toUpperCase() : s.status;
      const row = el("tr", {}, el("td", { text: s.start_shown || s.start_time || "" }),
        el("td", { class: s.status, text: status }), el("td", { text: blocks }), el("td", { text: s.kind }),
        el("td", { class: "sample text", text: s.sample }), el("td", { class: "text", text: s.operator }), el("td", { class: "text" }, link), action);
      const out = [row];
      if (s.note && !["success", "running"].includes(s.status)) out.push(el("tr", {}, el("td", { colspan: 8, class: "note", text: s.note })));
      return out;
    }).flat();
    table.replaceChildren(head, ...rows);
    if (!rows.length) table.append(el("tr", {}, el("td", { colspan: 8, text: "(no session files)" })));
  };
  filter.addEventListener("input", load);
  await load();
}

async function resume(path, sim) {
  const r = await api("/api/runs", { resume: true, output: path, sim, client: CLIENT });
  if (r.error) { alertBox(r.error); return; }
  location.hash = `#/run/${encodeURIComponent(r.id)}`;
}

function alertBox(text) {
  const box = el("p", { class: "error", id: "error", text });
  document.getElementById("main").prepend(box);
}

// ---- new session -------------------------------------------------------------------------------------------
async function showNew() {
  const scenes = await api("/api/scenes");
  const scene = el("select", { id: "scene" }, ...(scenes.scenes || []).map((s) => el("option", { value: s.id, text: s.label })));
  const sim = el("input", { type: "checkbox", id: "sim", checked: "checked" });
  const speed = el("input", { id: "sim-speed", value: "1000", size: 8 });
  const declared = await api("/api/overrides");
  const fields = {};
  const rows = (declared.overrides || []).map((o) => {
    const input = el("input", { id: `ov-${o.key.replace(".", "-")}`, size: 40, placeholder: `the scene's ${o.scene_key}` });
    fields[o.key] = input;
    input.addEventListener("change", () => preview());
    return el("label", {}, `${o.option.slice(2)}${o.sim_only ? " (simulated bench)" : ""}: `, input, el("span", { class: "small", text: ` ${o.help}` }));
  });
  const stamp = new Date().toISOString().slice(0, 19).replace(/[-:]/g, "").replace("T", "-");
  const name = el("input", { id: "output", value: `session-${stamp}.h5`, size: 40 });
  const plan = el("pre", { id: "plan" });
  const error = el("p", { class: "error", id: "form-error" });
  const form = { scene, sim, speed, fields };
  let asked = 0; // only the latest preview is shown (answers may come back out of order)
  const preview = async () => {
    const mine = ++asked;
    const r = await api("/api/plan", body(form));
    if (mine !== asked) return;
    plan.textContent = r.error ? "" : r.lines.join("\n") + `\nbench address: ${r.address}`;
    error.textContent = r.error || "";
  };
  for (const i of [scene, sim, speed]) i.addEventListener("change", preview);
  const start = el("button", { id: "start", class: "go", text: "Start session" });
  start.addEventListener("click", async () => {
    const r = await api("/api/runs", { ...body(form), output: name.value, client: CLIENT });
    if (r.error) { error.textContent = r.error; return; }
    location.hash = `#/run/${encodeURIComponent(r.id)}`;
  });
  main(el("h1", { text: "New session" }),
    el("label", {}, "Scene: ", scene),
    el("label", {}, sim, " simulated bench (no instruments); instrument time × 1/", speed),
    el("h2", { text: "This run (over the scene)" }), ...rows,
    el("label", {}, "Session file (in the console's folder): ", name),
    el("h2", { text: "Plan" }), plan, error, el("p", { class: "buttons" }, start));
  await preview();
}

function body(form) {
  const overrides = {};
  for (const [key, input] of Object.entries(form.fields)) if (input.value) overrides[key] = input.value;
  return { scene: form.scene.value, sim: form.sim.checked, sim_speed: form.speed.value, overrides };
}

// ---- the running session -----------------------------------------------------------------------------------
function showRun(id) {
  const status = el("p", { class: "status", id: "phase" });
  const weight = el("div", { class: "weight", id: "weight" });
  const ask = el("div", { class: "buttons", id: "ask" });
  const stops = el("div", { class: "buttons" },
    el("button", { id: "btn-stop-after", onclick: () => stop(id, false), text: "Stop after this block" }),
    el("button", { id: "btn-stop-now", class: "danger", onclick: () => stop(id, true), text: "Stop now" }));
  const canvas = el("canvas", { id: "plot", width: 720, height: 360, "data-points": 0 });
  const info = el("p", { id: "info" });
  const block = el("p", { id: "block" });
  const ended = el("div", { id: "ended" });
  const lines = el("pre", { id: "lines" });
  let overlays = [], last = { blocks: [], readings: [] };
  const toggle = el("span");
  main(el("h1", { id: "run-title", text: "Session" }), status, weight, ask, stops, info, toggle, canvas, block, ended,
    el("h2", { text: "Plan and notes" }), lines);
  let answered = -1;
  source = new EventSource(`/api/runs/${encodeURIComponent(id)}/events`);
  source.onmessage = (m) => {
    const s = JSON.parse(m.data);
    document.getElementById("run-title").textContent = `Session ${s.file}`;
    status.textContent = `${s.phase} — ${s.blocks_before + s.blocks.length} of ${s.blocks_planned} blocks` + (s.stop_requests ? ` — stop requested (${s.stop_requests})` : "");
    const lastBlock = s.blocks[s.blocks.length - 1];
    const invalid = s.blocks.reduce((a, b) => a + b.n_invalid, 0);
    info.textContent = `ETA ${fmtDuration(s.eta_s)} measuring + ${s.weights_left} weight(s) still to place · invalid readings ${invalid}` + (s.sim ? " · simulated bench" : ` · ${s.address}`);
    const b = lastBlock;
    block.textContent = b ? `last block #${b.block}: ${b.weight_kg} kg repeat ${b.repeat}: R = ${fmtOhm(b.mean_ohm)} ± ${fmtOhm(b.sem_ohm)} (n = ${b.n}, ${b.n_invalid} invalid)` + (b.compliance ? " COMPLIANCE: excluded" : "") : "";
    last = { blocks: s.blocks, readings: lastBlock ? lastBlock.readings_ohm : [] };
    if (!toggle.firstChild) toggle.append(overlayToggle(s.sample, s.file, (o) => { overlays = o; drawPlot(canvas, last.blocks, last.readings, overlays); }));
    drawPlot(canvas, s.blocks, last.readings, overlays);
    if (s.prompt && s.version !== answered) renderAsk(ask, weight, id, s, () => { answered = s.version; });
    if (!s.prompt) { ask.replaceChildren(); weight.textContent = s.phase === "ended" ? "" : weight.textContent; }
    lines.textContent = s.lines.join("\n");
    if (s.phase === "ended") {
      source.close();
      weight.textContent = "";
      stops.replaceChildren();
      const stopText = s.stop ? `${s.stop.status}: ${s.stop.reason} (${s.stop.blocks_done} of ${s.stop.blocks_planned} blocks)` : (s.end && s.end.error) || "ended";
      ended.replaceChildren(el("p", { id: "stop-record", text: `Stop record — ${stopText}` }),
        el("a", { id: "to-session", href: `#/session/${encodeURIComponent(s.file)}`, text: "the finished session" }));
    }
  };
}

function renderAsk(ask, weight, id, s, done) {
  const p = s.prompt;
  const send = async (answer) => { done(); ask.replaceChildren(); await api(`/api/runs/${encodeURIComponent(id)}/answer`, answer); };
  if (p.event === "resume_choice") {
    weight.textContent = `${p.weight_kg} kg was skipped`;
    ask.replaceChildren(
      el("button", { id: "btn-measure", class: "go", onclick: () => send({ measure: true }), text: "Measure it now" }),
      el("button", { id: "btn-keep", onclick: () => send({ measure: false }), text: "Keep it skipped" }));
    return;
  }
  weight.textContent = `Place ${p.weight_kg} kg`;
  const confirmBox = el("span");
  ask.replaceChildren(
    el("button", { id: "btn-continue", class: "go", onclick: () => send({ decision: "go" }), text: "Continue" }),
    el("button", { id: "btn-skip", onclick: () => confirmBox.replaceChildren(el("span", { class: "confirm", text: `skip ${p.weight_kg} kg? ` }),
      el("button", { id: "btn-confirm-skip", onclick: () => send({ decision: "skip" }), text: "Yes, skip" }),
      el("button", { onclick: () => confirmBox.replaceChildren(), text: `No, ${p.weight_kg} kg stays` })), text: "Skip" }),
    el("button", { id: "btn-quit", class: "danger", onclick: () => send({ decision: "quit" }), text: "Stop" }),
    el("span", { class: "small", text: ` (${p.repeats_left} block(s) to measure at this weight)` }), confirmBox);
}

async function stop(id, now, confirm) {
  const r = await api(`/api/runs/${encodeURIComponent(id)}/stop`, { now, client: CLIENT, confirm: !!confirm });
  if (r._status === 409 && r.confirm) {
    const box = el("div", { class: "confirm", id: "confirm-stop" }, el("span", { text: r.confirm + " " }),
      el("button", { id: "btn-confirm-stop", onclick: () => { box.remove(); stop(id, now, true); }, text: "Yes, stop it" }),
      el("button", { onclick: () => box.remove(), text: "No" }));
    document.getElementById("ask").after(box);
  }
}

// R against weight: every block (a repeat) as a dot, mean ± 1 SEM over the repeats per weight as a bar, blocks in
// compliance as red crosses on the axis; the current block's readings as a strip on the right.
function drawPlot(canvas, blocks, readings, overlays) {
  const ctx = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, left = 70, right = 150, top = 15, bottom = 35;
  ctx.clearRect(0, 0, W, H);
  const ok = blocks.filter((b) => !b.compliance && b.mean_ohm !== null);
  canvas.setAttribute("data-points", String(ok.length));
  ctx.strokeStyle = "#333"; ctx.fillStyle = "#333"; ctx.font = "12px sans-serif";
  ctx.strokeRect(left, top, W - left - right, H - top - bottom);
  ctx.fillText("weight [kg]", (W - right) / 2, H - 5);
  ctx.save(); ctx.translate(12, H / 2); ctx.rotate(-Math.PI / 2); ctx.fillText("R [mΩ]", 0, 0); ctx.restore();
  const past = (overlays || []).flatMap((o) => o.points);
  if (!blocks.length && !past.length) return;
  const ws = [...blocks.map((b) => b.weight_kg), ...past.map((p) => p.weight_kg)];
  const rs = [...ok.map((b) => b.mean_ohm), ...past.map((p) => p.mean_ohm)];
  const wmin = Math.min(...ws), wmax = Math.max(...ws) === wmin ? wmin + 1 : Math.max(...ws);
  const rmin = rs.length ? Math.min(...rs) : 0, rmax0 = rs.length ? Math.max(...rs) : 1, rmax = rmax0 === rmin ? rmin * 1.01 + 1e-9 : rmax0;
  const x = (w) => left + 10 + (w - wmin) / (wmax - wmin) * (W - left - right - 20);
  const y = (r) => H - bottom - 10 - (r - rmin) / (rmax - rmin) * (H - top - bottom - 20);
  ctx.fillText((rmax * 1e3).toPrecision(4), 2, top + 10); ctx.fillText((rmin * 1e3).toPrecision(4), 2, H - bottom - 5);
  ctx.fillText(String(wmin), left, H - bottom + 14); ctx.fillText(String(wmax), W - right - 30, H - bottom + 14);
  ctx.strokeStyle = "#bbb"; ctx.lineWidth = 1;
  for (const o of overlays || []) {
    ctx.beginPath();
    o.points.forEach((p, i) => (i ? ctx.lineTo(x(p.weight_kg), y(p.mean_ohm)) : ctx.moveTo(x(p.weight_kg), y(p.mean_ohm))));
    ctx.stroke();
  }
  canvas.setAttribute("data-overlaid", String((overlays || []).length));
  ctx.fillStyle = "#48c";
  for (const b of ok) { ctx.beginPath(); ctx.arc(x(b.weight_kg), y(b.mean_ohm), 3, 0, 2 * Math.PI); ctx.fill(); }
  const byW = new Map();
  for (const b of ok) byW.set(b.weight_kg, [...(byW.get(b.weight_kg) || []), b.mean_ohm]);
  ctx.strokeStyle = "#000"; ctx.lineWidth = 2;
  for (const [w, v] of byW) {
    const m = v.reduce((a, c) => a + c, 0) / v.length;
    const sd = v.length > 1 ? Math.sqrt(v.reduce((a, c) => a + (c - m) ** 2, 0) / (v.length - 1)) : 0;
    const sem = sd / Math.sqrt(v.length);
    ctx.beginPath(); ctx.moveTo(x(w) + 6, y(m - sem)); ctx.lineTo(x(w) + 6, y(m + sem)); ctx.stroke();
    ctx.beginPath(); ctx.moveTo(x(w) + 2, y(m)); ctx.lineTo(x(w) + 10, y(m)); ctx.stroke();
  }
  ctx.strokeStyle = "#c00"; ctx.lineWidth = 2;
  for (const b of blocks.filter((b) => b.compliance)) {
    const cx = x(b.weight_kg), cy = H - bottom - 5;
    ctx.beginPath(); ctx.moveTo(cx - 4, cy - 4); ctx.lineTo(cx + 4, cy + 4); ctx.moveTo(cx + 4, cy - 4); ctx.lineTo(cx - 4, cy + 4); ctx.stroke();
  }
  const vals = (readings || []).filter((v) => v !== null);
  if (vals.length) {
    const lo = Math.min(...vals), hi = Math.max(...vals) === lo ? lo + 1e-12 : Math.max(...vals);
    ctx.fillStyle = "#333"; ctx.fillText("current block", W - right + 20, top + 10);
    ctx.fillStyle = "#888";
    vals.forEach((v, i) => ctx.fillRect(W - right + 20 + i / vals.length * (right - 30), H - bottom - 10 - (v - lo) / (hi - lo) * (H - top - bottom - 40), 2, 2));
  }
  ctx.lineWidth = 1;
}

// Past sessions of the same sample, overlaid on request (grey lines: per weight, the mean of their block means).
function overlayToggle(sample, leaveOut, redraw) {
  const box = el("input", { type: "checkbox", id: "overlay" });
  box.addEventListener("change", async () => {
    if (!box.checked) { redraw([]); return; }
    const r = await api(`/api/overlay?${new URLSearchParams({ sample: sample || "", leave_out: leaveOut })}`);
    redraw(r.sessions || []);
  });
  return el("label", { class: "small" }, box, " overlay past sessions of this sample");
}

// ---- a finished session ------------------------------------------------------------------------------------
async function showSession(path) {
  const d = await api(`/api/session?path=${encodeURIComponent(path)}`);
  const out = el("pre", { id: "action-output" });
  const links = el("p", { id: "action-links" });
  const action = (name, extra) => async () => {
    out.textContent = `running contactrig ${name}…`;
    const r = await api(`/api/session/${name}`, { path, ...(extra || {}) });
    out.textContent = r.error || [r.stdout, r.stderr].filter((t) => t).join("\n");
    if (r.link && r.code === 0) links.replaceChildren(el("a", { id: "report-link", href: r.link, target: "_blank", rel: "noopener", text: "open report.html" }));
    (r.written || []).forEach((w, i) => links.append(el("a", { class: "export", href: r.links[i], text: w }), " "));
  };
  if (d.error) { main(el("h1", { text: path }), el("p", { class: "error", text: d.error })); return; }
  const stop = d.stop ? `${d.stop.status}: ${d.stop.reason} — ${d.stop.blocks_done} of ${d.stop.blocks_planned} blocks, stopped ${d.stop.stopped}` : "no stop record (incomplete or running)";
  const history = el("table", { id: "history" }, el("tr", {}, el("th", { text: "run" }), el("th", { text: "started" }), el("th", { text: "stop" })),
    ...d.history.map((h) => el("tr", {}, el("td", { text: h.run }), el("td", { text: h.started || "" }), el("td", { text: h.stop ? `${h.stop.status}: ${h.stop.reason}` : "" }))));
  const blocks = el("table", { id: "blocks" }, el("tr", {}, ...["block", "run", "weight [kg]", "repeat", "R", "SEM", "n", "invalid", "compliance"].map((h) => el("th", { text: h }))),
    ...d.blocks.map((b) => el("tr", {}, el("td", { text: b.block }), el("td", { text: b.run ?? "" }), el("td", { text: b.weight_kg }), el("td", { text: b.repeat }),
      el("td", { text: fmtOhm(b.mean_ohm) }), el("td", { text: fmtOhm(b.sem_ohm) }), el("td", { text: b.n }), el("td", { text: b.n_invalid }), el("td", { text: b.compliance ? "yes" : "" }))));
  const canvas = el("canvas", { id: "plot", width: 720, height: 300 });
  main(el("h1", { id: "session-title", text: path }),
    el("p", {}, "status ", el("strong", { id: "session-status", text: d.status }), " · sample ", el("span", { id: "session-sample", text: d.sample ?? "" }), " · operator ", el("span", { text: d.operator ?? "" })),
    el("h2", { text: "Stop record" }), el("p", { id: "session-stop", text: stop }),
    el("p", { class: "buttons" },
      el("button", { id: "btn-fit", onclick: action("fit"), text: "Fit" }),
      el("button", { id: "btn-report", onclick: action("report"), text: "Report" }),
      el("button", { id: "btn-csv", onclick: action("export", { to: "csv" }), text: "Export CSV" }),
      el("button", { id: "btn-xlsx", onclick: action("export", { to: "xlsx" }), text: "Export xlsx" })),
    links, out, overlayToggle(d.sample, path, (o) => drawPlot(canvas, d.blocks, [], o)), canvas,
    el("h2", { text: "History" }), history, el("h2", { text: "Blocks" }), blocks);
  drawPlot(canvas, d.blocks, []);
}

// ---- routing -----------------------------------------------------------------------------------------------
function route() {
  if (source) { source.close(); source = null; }
  const hash = location.hash || "#/sessions";
  const [, page, ...rest] = hash.split("/");
  const arg = decodeURIComponent(rest.join("/"));
  if (page === "new") showNew();
  else if (page === "run") showRun(arg);
  else if (page === "session") showSession(arg);
  else showSessions();
}

window.addEventListener("hashchange", route);
document.addEventListener("DOMContentLoaded", route);
