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

function fmtDuration(s) {
  if (s === null || s === undefined) return "—";
  if (s < 60) return `${Math.round(s)} s`;
  return `${Math.floor(s / 60)} min ${String(Math.round(s % 60)).padStart(2, "0")} s`;
}

// ---- sessions: the run index (daq.run_index), searched with the filters of `contactrig sessions --where` ---------
let sortKey = "start";
const chosen = []; // the sessions picked to compare (two at most; the oldest pick drops out)
// the filters: [element id, label, --where key and operator, input type]
const FILTERS = [["f-text", "notes and remarks contain", "text~", "search"], ["f-sample", "sample", "sample~", "text"],
  ["f-operator", "operator", "operator~", "text"], ["f-scene", "scene", "scene~", "text"], ["f-serial", "instrument serial", "serial=", "text"],
  ["f-tag", "tag", "tag=", "text"], ["f-from", "started from (UTC day)", "start>=", "date"], ["f-to", "started until (UTC day)", "start<=", "date"],
  ["f-value", "recorded value", "", "text"]]; // f-value: a whole condition on any value recorded at the start, e.g. settings.delta.nplc=2
const STATUSES = ["", "success", "aborted", "failed", "running", "incomplete", "corrupt", "newer"];
const VERDICTS = ["", "discriminates", "undecided", "stale", "none"]; // the last fit's (--where verdict=)

function markText(m) { return `${m.text} — ${m.who}, ${m.at}`; }

async function showSessions() {
  const inputs = {};
  const boxes = FILTERS.map(([id, label, , type]) => {
    inputs[id] = el("input", { id, type, placeholder: type === "search" ? "search: words in notes and remarks" : id === "f-value" ? "settings.delta.nplc=2" : "" });
    return el("label", { class: type === "search" ? "search" : "filter" }, `${label} `, inputs[id]);
  });
  const status = el("select", { id: "f-status" }, ...STATUSES.map((s) => el("option", { value: s, text: s || "any" })));
  const verdict = el("select", { id: "f-verdict" }, ...VERDICTS.map((v) => el("option", { value: v, text: v || "any" })));
  const table = el("table", { id: "sessions-table" });
  const runsBox = el("div", { id: "console-runs" });
  const state = el("p", { id: "index-state", class: "small" });
  // the count of sessions that match and the page shown (PAGE_ROWS of contactrig/console/catalog.py a page)
  let offset = 0;
  const counted = el("span", { id: "index-count" });
  const prev = el("button", { id: "page-prev", disabled: "disabled", text: "◀ newer page" });
  const next = el("button", { id: "page-next", disabled: "disabled", text: "next page ▶" });
  prev.addEventListener("click", () => { offset = Math.max(0, offset - pageRows); load(false); });
  next.addEventListener("click", () => { offset += pageRows; load(false); });
  let pageRows = 500;
  const compare = el("button", { id: "btn-compare", disabled: "disabled", text: "Why do these two runs differ?" });
  compare.addEventListener("click", () => { location.hash = `#/diff/${encodeURIComponent(JSON.stringify(chosen))}`; });
  main(el("h1", { text: "Sessions" }), runsBox, boxes[0], el("div", { class: "filters" }, ...boxes.slice(1), el("label", { class: "filter" }, "status ", status), el("label", { class: "filter" }, "last fit ", verdict)),
    el("p", {}, compare, el("span", { id: "compare-picked", class: "small" })), state, el("p", { id: "pager" }, prev, " ", counted, " ", next), table);
  const runs = await api("/api/runs");
  if ((runs.runs || []).length) runsBox.append(el("h2", { text: "Started from this console" }));
  for (const r of runs.runs || []) {
    runsBox.append(el("p", {}, el("a", { href: `#/run/${encodeURIComponent(r.id)}`, text: `${r.file}: ${r.phase}, ` + (r.budget_min === null || r.budget_min === undefined ? `${r.blocks}/${r.blocks_planned} blocks` : `${r.blocks} blocks (adaptive, budget ${r.budget_min} min)`) })));
  }
  const picked = () => {
    compare.disabled = chosen.length !== 2;
    document.getElementById("compare-picked").textContent = chosen.length ? ` A: ${chosen[0]}` + (chosen[1] ? ` · B: ${chosen[1]}` : " (pick one more)") : " (tick two sessions)";
  };
  picked();
  let asked = 0, shownGeneration = -1, timer = null;
  const load = async (kick, poll) => {
    const mine = ++asked;
    if (timer) { clearTimeout(timer); timer = null; }
    const q = new URLSearchParams({ sort: sortKey, order: sortKey === "start" ? "desc" : "asc" }); // newest first; A to Z
    if (!kick) q.set("kick", "0");
    if (offset) q.set("offset", String(offset));
    for (const [id, , key] of FILTERS) if (inputs[id].value.trim()) q.append("where", key + inputs[id].value.trim());
    if (status.value) q.append("where", `status=${status.value}`);
    if (verdict.value) q.append("where", `verdict=${verdict.value}`);
    const data = await api(`/api/sessions?${q}`);
    if (mine !== asked || !document.body.contains(table)) return; // a newer search, or another page, meanwhile
    if (data.indexing) timer = setTimeout(() => { if (document.body.contains(table)) load(false, true); }, 700);
    state.textContent = (data.error ? `${data.error} ` : "") + (data.indexing ? "updating the index from the files… (shown: the index as it is) " : "")
      + (data.notes || []).join(" ");
    state.className = data.error ? "error" : "small";
    if (data.error) return;
    if (poll && data.generation === shownGeneration) return; // nothing new: the table stays as it is
    shownGeneration = data.generation;
    pageRows = data.page || pageRows;
    const n = (data.sessions || []).length;
    counted.textContent = `${data.matched} session${data.matched === 1 ? "" : "s"} match` + (data.matched ? `; shown ${data.offset + (n ? 1 : 0)}–${data.offset + n}` : "");
    prev.disabled = !data.offset;
    next.disabled = !data.more;
    const cols = [["", null], ["start", "start"], ["status", "status"], ["blocks", null], ["kind", null], ["sample", "sample"], ["operator", "operator"], ["last fit", null], ["file", "path"], ["tags", null], ["", null]];
    const head = el("tr", {}, ...cols.map(([name, key]) => {
      const th = el("th", { text: name + (key === sortKey ? " ▾" : "") });
      if (key) th.addEventListener("click", () => { sortKey = key; offset = 0; load(false); });
      return th;
    }));
    const rows = (data.sessions || []).map((s) => {
      const blocks = s.blocks_done === null ? "" : `${s.blocks_done}/${s.blocks_planned ?? "?"}` + (s.compliant_blocks ? ` (${s.compliant_blocks} compliance)` : "");
      const link = el("a", { href: `#/session/${encodeURIComponent(s.path)}`, text: s.path });
      const action = el("td");
      if (s.status === "aborted" || s.status === "incomplete" || s.status === "failed") {
        action.append(el("button", { class: "resume", onclick: () => resume(s.path, s.kind === "simulated"), text: "Resume" }));
      }
      if (s.status === "running") action.append(el("a", { class: "follow", href: `#/follow/${encodeURIComponent(s.path)}`, text: "Follow live" }));
      const pick = el("input", { type: "checkbox", class: "pick", title: "compare" });
      pick.checked = chosen.includes(s.path);
      pick.addEventListener("change", () => {
        const at = chosen.indexOf(s.path);
        if (pick.checked && at < 0) chosen.push(s.path);
        if (!pick.checked && at >= 0) chosen.splice(at, 1);
        while (chosen.length > 2) chosen.shift();
        for (const box of table.querySelectorAll("input.pick")) box.checked = chosen.includes(box.dataset.path);
        picked();
      });
      pick.dataset.path = s.path;
      const tags = el("td", { class: "tags" }, ...(s.tags || []).map((t) => el("span", { class: "tag", title: `${t.who}, ${t.at}`, text: t.text })));
      const st = ["corrupt", "newer"].includes(s.status) ? s.status.toUpperCase() : s.status;
      const f = s.fit; // the last fit's verdict (contactrig fit), stale when made with another analysis version
      const fit = el("td", f ? { class: f.stale ? "fit stale" : "fit", title: `${f.statement} — analysis ${f.analysis_version}, ${f.who}, ${f.at}`,
        text: `${f.verdict} ${f.best}` + (f.stale ? ` (stale: ${f.analysis_version})` : "") } : {});
      const row = el("tr", {}, el("td", {}, pick), el("td", { text: s.start_shown || s.start_time || "" }),
        el("td", { class: s.status, text: st }), el("td", { text: blocks }), el("td", { text: s.kind }),
        el("td", { class: "sample text", text: s.sample }), el("td", { class: "text", text: s.operator }), fit, el("td", { class: "text" }, link), tags, action);
      const out = [row];
      if (s.note && !["success", "running"].includes(s.status)) out.push(el("tr", {}, el("td", { colspan: 11, class: "note", text: s.note })));
      for (const m of s.remarks || []) out.push(el("tr", {}, el("td"), el("td", { colspan: 10, class: "remark text", text: `remark: ${markText(m)}` })));
      return out;
    }).flat();
    table.replaceChildren(head, ...rows);
    if (!rows.length) table.append(el("tr", {}, el("td", { colspan: 11, text: data.indexing ? "(the index is being built…)" : "(no session matches)" })));
  };
  let typing = null;
  const later = () => { clearTimeout(typing); typing = setTimeout(() => { offset = 0; load(false); }, 250); };
  for (const i of Object.values(inputs)) i.addEventListener("input", later);
  status.addEventListener("change", () => { offset = 0; load(false); });
  verdict.addEventListener("change", () => { offset = 0; load(false); });
  await load(true);
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
  // adaptive (acquire --adaptive --budget-min N): the next placement chosen as the session goes
  const adaptive = el("input", { type: "checkbox", id: "adaptive" });
  const budget = el("input", { id: "budget-min", value: "60", size: 6 });
  // its prior noise from an earlier session of this bench (acquire --adaptive --noise-from SESSION.h5); empty: Tab. 1's
  const noiseFrom = el("input", { id: "noise-from", size: 30, placeholder: "Tab. 1's (simulated: the scene's)" });
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
  const form = { scene, sim, speed, fields, adaptive, budget, noiseFrom };
  let asked = 0; // only the latest preview is shown (answers may come back out of order)
  const preview = async () => {
    const mine = ++asked;
    const r = await api("/api/plan", body(form));
    if (mine !== asked) return;
    plan.textContent = r.error ? "" : r.lines.join("\n") + `\nbench address: ${r.address}`
      + (adaptive.checked && !r.error ? `\nadaptive: the weights above are the placements allowed; the blocks and the time follow the suggestions, within ${budget.value || 60} min of bench time` : "");
    error.textContent = r.error || "";
  };
  for (const i of [scene, sim, speed, adaptive, budget]) i.addEventListener("change", preview);
  const start = el("button", { id: "start", class: "go", text: "Start session" });
  start.addEventListener("click", async () => {
    const r = await api("/api/runs", { ...body(form), output: name.value, client: CLIENT });
    if (r.error) { error.textContent = r.error; return; }
    location.hash = `#/run/${encodeURIComponent(r.id)}`;
  });
  const wait = el("input", { type: "checkbox", id: "queue-wait" });
  const enqueue = el("button", { id: "btn-enqueue", text: "Add to the queue" });
  enqueue.addEventListener("click", async () => {
    const r = await api("/api/queue", { ...body(form), output: name.value, wait: wait.checked, client: CLIENT });
    if (r.error) { error.textContent = r.error; return; }
    location.hash = "#/queue";
  });
  main(el("h1", { text: "New session" }),
    el("label", {}, "Scene: ", scene),
    el("label", {}, sim, " simulated bench (no instruments); instrument time × 1/", speed),
    el("label", {}, adaptive, " adaptive: each next placement suggested as the session goes, until decisive or futile; budget (min) ", budget),
    el("label", {}, "adaptive: prior noise from the session file (in the console's folder) ", noiseFrom),
    el("h2", { text: "This run (over the scene)" }), ...rows,
    el("label", {}, "Session file (in the console's folder): ", name),
    el("h2", { text: "Plan" }), plan, error, el("p", { class: "buttons" }, start),
    el("p", {}, enqueue, el("label", { class: "inline" }, wait, " waits for my Start (else: starts when its bench is free)")));
  await preview();
}

function body(form) {
  const overrides = {};
  for (const [key, input] of Object.entries(form.fields)) if (input.value) overrides[key] = input.value;
  const out = { scene: form.scene.value, sim: form.sim.checked, sim_speed: form.speed.value, overrides };
  if (form.adaptive && form.adaptive.checked) Object.assign(out, { adaptive: true, budget_min: form.budget.value });
  if (form.adaptive && form.adaptive.checked && form.noiseFrom.value) out.noise_from = form.noiseFrom.value;
  return out;
}

// ---- the running session -----------------------------------------------------------------------------------
function showRun(id) {
  const status = el("p", { class: "status", id: "phase" });
  const weight = el("div", { class: "weight", id: "weight" });
  const ask = el("div", { class: "buttons", id: "ask" });
  const stops = el("div", { class: "buttons" },
    el("button", { id: "btn-stop-after", onclick: () => stop(id, false), text: "Stop after this block" }),
    el("button", { id: "btn-stop-now", class: "danger", onclick: () => stop(id, true), text: "Stop now" }));
  const pauseBox = pauseControls(id);
  const canvas = el("div", { id: "plot", "data-points": 0 });
  const readingsBox = el("div", { id: "readings" });
  const info = el("p", { id: "info" });
  const block = el("p", { id: "block" });
  const ended = el("div", { id: "ended" });
  const lines = el("pre", { id: "lines" });
  const evidence = el("div", { id: "evidence", hidden: "hidden" });
  const drawEvidence = evidenceBox(evidence);
  let overlays = [], last = { blocks: [], readings: [] };
  // the blocks on file before this run (a resumed session: the plot shows every block, not only this run's)
  let onFile = { blocks: [], weights: [] }, asked = false;
  const redraw = () => drawPlot(canvas, { blocks: merged(onFile.blocks, last.blocks), weights: onFile.weights, overlays });
  const toggle = el("span");
  const refused = el("p", { class: "refused", id: "answer-refused", role: "alert", hidden: "hidden" });
  main(el("h1", { id: "run-title", text: "Session" }), status, refused, weight, ask, evidence, stops, pauseBox.box, info, toggle, canvas, readingsBox, block, ended,
    el("h2", { text: "Plan and notes" }), lines);
  let shown = null; // the id of the question shown: each question is rendered (and answered) once
  source = new EventSource(`/api/runs/${encodeURIComponent(id)}/events`);
  source.addEventListener("closed", () => { source.close(); status.textContent += " — the console has stopped"; });
  source.onmessage = (m) => {
    const s = JSON.parse(m.data);
    document.getElementById("run-title").textContent = `Session ${s.file}`;
    const count = s.budget_min === null ? `${s.blocks_before + s.blocks.length} of ${s.blocks_planned} blocks` : `${s.blocks.length} blocks (adaptive, budget ${s.budget_min} min)`;
    status.textContent = `${s.phase} — ${count}` + (s.stop_requests ? ` — stop requested (${s.stop_requests})` : "") + (s.console_closing ? " — the console is shutting down: sessions stop after their block" : "");
    const lastBlock = s.blocks[s.blocks.length - 1];
    const invalid = s.blocks.reduce((a, b) => a + b.n_invalid, 0);
    info.textContent = (s.budget_min === null ? `ETA ${fmtDuration(s.eta_s)} measuring + ${s.weights_left} weight(s) still to place · ` : "") + `invalid readings ${invalid}` + (s.sim ? " · simulated bench" : ` · ${s.address}`);
    // once ended: the design's stop decision, or (stopped by Ctrl-C / Stop after this block) the stop record's
    const decided = s.adaptive_stop && s.adaptive_stop.decision ? s.adaptive_stop : s.stop ? { decision: { status: s.stop.status }, stop_reason: s.stop.reason } : null;
    if (s.adaptive) drawEvidence(s.adaptive, s.phase === "ended" ? decided : null);
    const b = lastBlock;
    block.textContent = b ? `last block ${b.number}/${s.blocks_planned}: ${b.weight_kg} kg repeat ${b.repeat}: ` + (b.compliance ? "COMPLIANCE: excluded" : `R = ${b.mean_text || "—"}${b.sem_text ? ` ± ${b.sem_text}` : ""} (SEM, n = ${b.n}, ${b.n_invalid} invalid)`) : "";
    last = { blocks: s.blocks, readings: lastBlock ? lastBlock.readings_ohm : [] };
    if (!toggle.firstChild) toggle.append(overlayToggle(s.sample, s.file, (o) => { overlays = o; redraw(); }));
    if (!asked && (s.resume || s.blocks.length)) { // the file exists: read what it holds (lock-free, while written)
      asked = true;
      api(`/api/session?path=${encodeURIComponent(s.file)}`).then((d) => { if (!d.error) { onFile = d; redraw(); } });
    }
    redraw();
    if (last.readings && last.readings.length) Plot.drawReadings(readingsBox, last.readings);
    if (s.prompt && s.prompt.id !== shown) { shown = s.prompt.id; renderAsk(ask, weight, id, s, refused); }
    if (!s.prompt) { shown = null; keys = null; ask.replaceChildren(); weight.textContent = s.phase === "ended" ? "" : weight.textContent; }
    lines.textContent = s.lines.join("\n");
    pauseBox.update(s);
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

// The question asked now, answered once: the answer names the question's id; the console refuses (409) an answer to
// a question that is no longer asked (answered from another page, a double click, a late request), shown here.
let keys = null; // the keys of the question shown (Enter / s / q, as at the terminal), or null

function renderAsk(ask, weight, id, s, refused) {
  const p = s.prompt;
  const send = async (answer) => {
    keys = null;
    ask.replaceChildren();
    let r;
    try { r = await api(`/api/runs/${encodeURIComponent(id)}/answer`, { prompt: p.id, ...answer }); }
    catch (e) { r = { error: `the console did not answer (${e})` }; }
    if (r.error) {
      refused.textContent = `${r._status === 409 ? "Answer refused" : "Answer not taken"} (${new Date().toLocaleTimeString()}): ${r.error}`;
      refused.hidden = false;
      if (r._status !== 409) renderAsk(ask, weight, id, s, refused); // not refused for its question: ask again
    } else refused.hidden = true;
  };
  if (p.event === "resume_choice") {
    weight.textContent = `${p.weight_kg} kg was skipped`;
    const measure = () => send({ measure: true }), keep = () => send({ measure: false });
    ask.replaceChildren(
      el("button", { id: "btn-measure", class: "go", onclick: measure, text: "Measure it now" }),
      el("button", { id: "btn-keep", onclick: keep, text: "Keep it skipped" }),
      el("span", { class: "small", text: " (m measure it now, Enter keep it skipped)" }));
    keys = { m: measure, Enter: keep };
    return;
  }
  if (p.event === "suggest") { renderSuggestion(ask, weight, p, send); return; }
  weight.textContent = `Place ${p.weight_kg} kg`;
  const confirmBox = el("span");
  const go = () => send({ decision: "go" }), quit = () => send({ decision: "quit" });
  const no = () => { confirmBox.replaceChildren(); keys = mainKeys; };
  const skip = () => {
    confirmBox.replaceChildren(el("span", { class: "confirm", text: `skip ${p.weight_kg} kg? [y/N] ` }),
      el("button", { id: "btn-confirm-skip", onclick: () => send({ decision: "skip" }), text: "Yes, skip" }),
      el("button", { id: "btn-keep-weight", onclick: no, text: `No, ${p.weight_kg} kg stays` }));
    keys = { y: () => send({ decision: "skip" }), n: no, Enter: no, Escape: no };
  };
  const mainKeys = { Enter: go, s: skip, q: quit };
  ask.replaceChildren(
    el("button", { id: "btn-continue", class: "go", onclick: go, text: "Continue" }),
    el("button", { id: "btn-skip", onclick: skip, text: "Skip" }),
    el("button", { id: "btn-quit", class: "danger", onclick: quit, text: "Stop" }),
    el("span", { class: "small", text: ` (${p.repeats_left} block(s) to measure at this weight; Enter continue, s skip, q stop)` }), confirmBox);
  keys = mainKeys;
}

// An adaptive session's next placement (analysis.sequential's suggestion, in its words) as the big prompt: take it
// (Enter, as at the terminal), place another of the allowed weights (as typing a weight there), or stop (q).
function renderSuggestion(ask, weight, p, send) {
  // big: what to do ("place 7.44 kg (2 seatings)"); beneath it, the rest of the analysis's sentence (why, or the
  // expected gain per minute)
  const text = p.suggestion.text, why = p.suggestion.why;
  const cut = why ? text.lastIndexOf(`: ${why}`) : text.lastIndexOf(" (expected gain");
  weight.replaceChildren(el("span", { id: "suggestion", text: cut > 0 ? text.slice(0, cut) : text }),
    el("span", { id: "suggestion-detail", class: "small", text: cut > 0 ? text.slice(cut).replace(/^: /, "").trim() : "" }));
  const take = () => send({ decision: "go" }), quit = () => send({ decision: "quit" });
  const other = el("span", { id: "other-weight" });
  const another = () => {
    const pick = el("select", { id: "other-kg" }, ...p.allowed_kg.map((w) => el("option", { value: w, text: `${w} kg` })));
    other.replaceChildren(pick, el("button", { id: "btn-place-other", onclick: () => send({ decision: "place", weight_kg: Number(pick.value) }), text: "Place this one" }));
    pick.focus();
  };
  ask.replaceChildren(
    el("button", { id: "btn-take", class: "go", onclick: take, text: "Take the suggestion" }),
    el("button", { id: "btn-other", onclick: another, text: "Place another weight" }),
    el("button", { id: "btn-quit", class: "danger", onclick: quit, text: "Stop" }),
    el("span", { class: "small", text: " (Enter take it, o another weight, q stop)" }), other);
  keys = { Enter: take, o: another, q: quit };
}

// The evidence of an adaptive session (the design's report, as the child or the file gives it): the progress to a
// decision (the leader's margin against the decisive threshold), the reason when it does not move, and, once it has
// ended, why it stopped (decisive, futile or the operator; what would have to change).
function evidenceBox(box) {
  let before = null; // the progress shown last (the reason is shown while it does not rise)
  return (a, stopped) => {
    box.hidden = false;
    if (a.error) { box.replaceChildren(el("p", { class: "error", id: "evidence-error", text: a.error })); return; }
    const progress = Math.max(0, Math.min(1, a.progress || 0));
    const still = before === null ? progress === 0 : progress <= before;
    before = progress;
    const p = a.p_decisive === null || a.p_decisive === undefined ? "" : ` · P(decisive within the budget) ${Math.round(100 * a.p_decisive)} %`;
    const parts = [el("h2", { text: "Progress to a decision" }),
      el("p", {}, el("progress", { id: "evidence-bar", max: 1, value: progress }), el("span", { id: "evidence-pct", text: ` ${Math.round(100 * progress)} % of Δ = ${a.threshold}` })),
      el("p", { id: "evidence-line", text: (a.evidence_line || "") + p })];
    if (still && a.why) parts.push(el("p", { id: "evidence-why", class: "small", text: `not moving: ${a.why}` }));
    const end = stopped || (a.stop_record ? { decision: a.stop_record.decision, stop_reason: a.stop_record.reason } : null);
    if (end) {
      const status = (end.decision && end.decision.status) || (a.stop_record && a.stop_record.status) || "";
      const reason = end.stop_reason || (end.decision && end.decision.reason) || "";
      const label = reason.startsWith(`${status}:`) ? "" : `${status}: `; // "decisive: …" says it already
      parts.push(el("p", { id: "adaptive-stop", class: `stopped ${status}` }, el("strong", { text: label }), reason));
      if (status !== "decisive" && a.what_would && !reason.includes(a.what_would)) parts.push(el("p", { id: "adaptive-what-would", text: `what would: ${a.what_would}` }));
    }
    box.replaceChildren(...parts);
  };
}

// Keys answer the question shown, as at the terminal; a held key (repeat), a key with a modifier or typed into a
// field is not an answer. A focused button does not take Enter while a question is shown (the key answers it).
document.addEventListener("keydown", (e) => {
  if (!keys || e.repeat || e.ctrlKey || e.altKey || e.metaKey || e.isComposing) return;
  if (e.target instanceof Element && e.target.closest("input, select, textarea")) return;
  const key = e.key.length === 1 ? e.key.toLowerCase() : e.key;
  const act = keys[key];
  if (!act) return;
  e.preventDefault();
  act();
});

// Pause at the next block boundary with a reason (recorded in the session file with who and when), Resume from the
// same page; the records of this run's pauses as the file holds them.
function pauseControls(id) {
  const reason = el("input", { id: "pause-reason", placeholder: "reason for the pause", size: 40 });
  const who = el("input", { id: "pause-who", placeholder: "your name", size: 14 });
  const said = el("p", { class: "refused", id: "pause-refused", role: "alert", hidden: "hidden" });
  const state = el("p", { id: "pause-state" });
  const call = async (action, body) => {
    const r = await api(`/api/runs/${encodeURIComponent(id)}/${action}`, body);
    said.textContent = r.error ? `${action} refused: ${r.error}` : "";
    said.hidden = !r.error;
  };
  const pauseBtn = el("button", { id: "btn-pause", onclick: () => call("pause", { reason: reason.value, who: who.value }), text: "Pause after this block" });
  const resumeBtn = el("button", { id: "btn-resume", class: "go", onclick: () => call("resume", { who: who.value }), text: "Resume" });
  const box = el("div", { id: "pause-box" }, el("div", { class: "buttons" }, reason, who, pauseBtn, resumeBtn), said, state);
  const update = (s) => {
    if (s.phase === "ended") { box.replaceChildren(state); }
    const open = (s.pauses || []).filter((p) => !p.resumed);
    pauseBtn.disabled = s.phase === "paused" || !!s.pause_request;
    resumeBtn.disabled = !(s.phase === "paused" || s.pause_request);
    const now = s.phase === "paused" && open.length ? `PAUSED after block ${open[0].after_block} since ${open[0].paused} by ${open[0].who}: ${open[0].reason}`
      : s.pause_request ? `pause requested (${s.pause_request.reason}): after the block under way` : "";
    const past = (s.pauses || []).filter((p) => p.resumed).map((p) => `paused after block ${p.after_block}, ${p.paused} – ${p.resumed} (${p.who}: ${p.reason}; resumed by ${p.resumed_by})`);
    state.textContent = [now, ...past].filter(Boolean).join("\n");
  };
  return { box, update };
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

// R against weight (plot.js, uPlot): every block, mean ± 1 SEM per weight, compliance marked, past sessions and the
// fitted models' curves; `view` = { blocks, weights (planned), overlays, curves }.
function drawPlot(holder, view) {
  Plot.draw(holder, view);
}

// The blocks on file and this run's live blocks, each once (by run and block), in the order of the file.
function merged(fileBlocks, liveBlocks) {
  const seen = new Set(fileBlocks.map((b) => `${b.run}:${b.block}`));
  return [...fileBlocks, ...liveBlocks.filter((b) => !seen.has(`${b.run}:${b.block}`))];
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
    if (r.curves) { view.curves = r.curves; drawPlot(canvas, view); } // the models' fitted curves over the data
    if (r.link && r.code === 0) links.replaceChildren(el("a", { id: "report-link", href: r.link, target: "_blank", rel: "noopener", text: "open report.html" }));
    (r.written || []).forEach((w, i) => links.append(el("a", { class: "export", href: r.links[i], text: w }), " "));
  };
  if (d.error) { main(el("h1", { text: path }), el("p", { class: "error", text: d.error })); return; }
  const stop = d.stop ? `${d.stop.status}: ${d.stop.reason} — ${d.stop.blocks_done} of ${d.stop.blocks_planned} blocks, stopped ${d.stop.stopped}` : "no stop record (incomplete or running)";
  const history = el("table", { id: "history" }, el("tr", {}, el("th", { text: "run" }), el("th", { text: "started" }), el("th", { text: "stop" }), el("th", { text: "notes" })),
    ...d.history.map((h) => el("tr", {}, el("td", { text: h.run }), el("td", { text: h.started || "" }), el("td", { text: h.stop ? `${h.stop.status}: ${h.stop.reason}` : "" }), el("td", { class: "text", text: h.notes || "" }))));
  const blocks = el("table", { id: "blocks" }, el("tr", {}, ...["block", "run", "weight [kg]", "repeat", "R", "SEM", "n", "invalid", "compliance"].map((h) => el("th", { text: h }))),
    ...d.blocks.map((b) => el("tr", {}, el("td", { text: b.number }), el("td", { text: b.run ?? "" }), el("td", { text: b.weight_kg }), el("td", { text: b.repeat }),
      el("td", { text: b.mean_text || "—" }), el("td", { text: b.sem_text || "—" }), el("td", { text: b.n }), el("td", { text: b.n_invalid }), el("td", { text: b.compliance ? "yes" : "" }))));
  const canvas = el("div", { id: "plot", "data-points": 0 });
  const view = { blocks: d.blocks, weights: d.weights || [], overlays: [], curves: [] };
  main(el("h1", { id: "session-title", text: path }),
    el("p", {}, "status ", el("strong", { id: "session-status", text: d.status }), " · sample ", el("span", { id: "session-sample", text: d.sample ?? "" }), " · operator ", el("span", { text: d.operator ?? "" }),
      ` · ${d.runs} run(s)`),
    el("p", {}, "notes: ", el("span", { id: "session-notes", class: "text", text: d.notes || "(none)" })),
    marksBox(path, d.marks || []),
    d.status === "running" ? el("p", {}, el("a", { id: "to-follow", href: `#/follow/${encodeURIComponent(path)}`, text: "being written by another process: follow it live" })) : "",
    el("h2", { text: "Stop record" }), el("p", { id: "session-stop", text: stop }),
    el("p", { class: "buttons" },
      el("button", { id: "btn-fit", onclick: action("fit"), text: "Fit" }),
      el("button", { id: "btn-report", onclick: action("report"), text: "Report" }),
      el("button", { id: "btn-csv", onclick: action("export", { to: "csv" }), text: "Export CSV" }),
      el("button", { id: "btn-xlsx", onclick: action("export", { to: "xlsx" }), text: "Export xlsx" })),
    links, out, overlayToggle(d.sample, path, (o) => { view.overlays = o; drawPlot(canvas, view); }), canvas,
    el("h2", { text: "History" }), history, el("h2", { text: "Blocks" }), blocks);
  drawPlot(canvas, view);
}

// Tags and remarks (daq.run_index: the folder's sidecar, never the sealed session), with who and when; one more added
// here (who: remembered in this browser).
function marksBox(path, marks) {
  const list = el("ul", { id: "marks" });
  const show = (m) => list.append(el("li", { class: "text" }, el("strong", { text: `${m.kind}: ` }), markText(m)));
  marks.forEach(show);
  const kind = el("select", { id: "mark-kind" }, el("option", { value: "tag", text: "tag (one word)" }), el("option", { value: "remark", text: "remark" }));
  const text = el("input", { id: "mark-text", size: 50 });
  const who = el("input", { id: "mark-who", size: 16, value: localStorage.getItem("contactrig-who") || "" });
  const error = el("span", { class: "error", id: "mark-error" });
  const add = el("button", { id: "btn-mark", text: "Add" });
  add.addEventListener("click", async () => {
    const r = await api("/api/session/mark", { path, kind: kind.value, text: text.value, who: who.value });
    error.textContent = r.error || "";
    if (r.error) return;
    localStorage.setItem("contactrig-who", who.value);
    show(r.mark);
    text.value = "";
  });
  return el("div", { id: "marks-box" }, el("h2", { text: "Tags and remarks" }), list,
    el("p", {}, kind, " ", text, " by ", who, " ", add, " ", error));
}

// ---- why two runs differ (daq.session_diff): every field that differs, side by side -----------------------------
async function showDiff(arg) {
  let pair = [];
  try { pair = JSON.parse(arg); } catch (e) { pair = []; }
  main(el("h1", { text: "Why do these two runs differ?" }), el("p", { text: "comparing…" }));
  const d = await api(`/api/diff?${new URLSearchParams({ a: pair[0] || "", b: pair[1] || "" })}`);
  if (d.error) { main(el("h1", { text: "Why do these two runs differ?" }), el("p", { class: "error", id: "diff-error", text: d.error })); return; }
  const link = (p) => el("a", { href: `#/session/${encodeURIComponent(p)}`, text: p });
  const show = (v) => (v === null || v === undefined ? "—" : typeof v === "object" ? JSON.stringify(v) : String(v));
  const table = el("table", { id: "diff-table" }, el("tr", {}, el("th", { text: "field" }), el("th", {}, "A: ", link(d.a)), el("th", {}, "B: ", link(d.b))),
    ...d.differences.map((x) => el("tr", {}, el("td", { class: "field", text: x.field }), el("td", { class: "text", text: show(x.a) }), el("td", { class: "text", text: show(x.b) }))));
  if (!d.differences.length) table.append(el("tr", {}, el("td", { colspan: 3, text: "(no differences)" })));
  main(el("h1", { text: "Why do these two runs differ?" }), table,
    el("p", { id: "diff-same", text: `${d.same} field(s) the same` }),
    d.scene_lines.length ? el("h2", { text: "Scene text (- in A, + in B)" }) : "", d.scene_lines.length ? el("pre", { id: "diff-scene", text: d.scene_lines.join("\n") }) : "",
    ...d.notes.map((n) => el("p", { class: "small", text: `note: ${n}` })));
}

// ---- the bench's queue: planned sessions, started one after the other on their bench address ------------------------
let queueTimer = null;

async function showQueue() {
  const list = el("table", { id: "queue-table" });
  const said = el("p", { class: "error", id: "queue-error" });
  const started = el("div", { id: "queue-started" });
  main(el("h1", { text: "Queue" }), el("p", { class: "small", text: "Each planned session starts when the session before it on its bench has ended (or at your Start); the queue is kept in the folder, so it outlives a console restart." }),
    said, list, started, el("p", {}, el("a", { href: "#/new", text: "plan another session (New session → Add to the queue)" })));
  const act = async (id, action, extra) => {
    const r = await api(`/api/queue/${encodeURIComponent(id)}/${action}`, extra || {});
    said.textContent = r.error || "";
    draw(r.error ? null : r);
  };
  const draw = async (q) => {
    if (!q) q = await api("/api/queue");
    if (location.hash !== "#/queue") return;
    said.textContent = q.broken || said.textContent;
    const head = el("tr", {}, ...["#", "file", "scene", "bench", "overrides", "state", ""].map((h) => el("th", { text: h })));
    const rows = (q.items || []).map((it, k) => {
      const f = it.form;
      const state = it.error ? `refused: ${it.error}` : it.wait && !it.go ? "waits for your Start" : "starts when the bench is free";
      const ov = Object.entries(f.overrides || {}).map(([key, v]) => `${key}=${v}`).join(", ");
      return el("tr", { class: "queued" }, el("td", { text: k + 1 }), el("td", { class: "text", text: f.output }), el("td", { class: "text", text: f.scene || "(default)" }),
        el("td", { text: f.sim ? `${it.address} (simulated)` : it.address }), el("td", { class: "text", text: ov }), el("td", { class: it.error ? "error" : "", text: state }),
        el("td", {},
          el("button", { class: "up", onclick: () => act(it.id, "move", { to: Math.max(0, k - 1) }), text: "↑" }),
          el("button", { class: "down", onclick: () => act(it.id, "move", { to: Math.min(q.items.length - 1, k + 1) }), text: "↓" }),
          (it.wait && !it.go) || it.error ? el("button", { class: "go start", onclick: () => act(it.id, "start"), text: "Start" }) : "",
          el("button", { class: "cancel", onclick: () => act(it.id, "cancel"), text: "Cancel" })));
    });
    list.replaceChildren(head, ...rows);
    if (!rows.length) list.append(el("tr", {}, el("td", { colspan: 7, text: "(nothing queued)" })));
    started.replaceChildren(...(q.started || []).length ? [el("h2", { text: "Started from the queue" })] : [],
      ...(q.started || []).map((s) => el("p", {}, el("a", { class: "started", href: `#/run/${encodeURIComponent(s.run)}`, text: s.file }))));
  };
  const poll = async () => { queueTimer = null; await draw(); if (location.hash === "#/queue") queueTimer = setTimeout(poll, 1000); };
  await poll();
}

// ---- a session written by another process (`contactrig acquire` in a terminal), followed from its file ----------
// Status, plot and ETA as `contactrig watch` sees them; no Continue/Stop: control stays with the process that writes
// it (Enter / s / q and Ctrl-C at its terminal).
let followTimer = null;

function showFollow(path) {
  const status = el("p", { class: "status", id: "follow-status" });
  const line = el("pre", { id: "follow-line" });
  const who = el("p", { id: "follow-who", class: "small" });
  const holder = el("div", { id: "plot", "data-points": 0 });
  const readingsBox = el("div", { id: "readings" });
  const said = el("pre", { id: "follow-warnings" });
  const evidence = el("div", { id: "evidence", hidden: "hidden" });
  const drawEvidence = evidenceBox(evidence);
  main(el("h1", { id: "follow-title", text: `Following ${path}` }), status, who, line, evidence, holder, readingsBox, said);
  let weights = null; // the plan's weights, read once from the file's start record
  const poll = async () => {
    followTimer = null;
    const s = await api(`/api/follow?path=${encodeURIComponent(path)}`);
    if (location.hash !== `#/follow/${encodeURIComponent(path)}`) return; // left the page meanwhile
    if (s.error) { status.textContent = s.error; followTimer = setTimeout(poll, 2000); return; }
    status.textContent = `${s.status} — ${s.blocks.length} of ${s.blocks_planned ?? "?"} blocks` + (s.running ? ` — ETA ${fmtDuration(s.eta_s)}` : "");
    who.replaceChildren(s.run
      ? el("a", { id: "follow-run", href: `#/run/${encodeURIComponent(s.run)}`, text: "started from this console: its page has the controls" })
      : `written by: ${s.command}${s.host ? ` on ${s.host}` : ""} — control stays with that process (its terminal: Enter / s / q, Ctrl-C)`);
    line.textContent = s.status_line;
    if (s.adaptive) drawEvidence(s.adaptive, null); // an adaptive session: the evidence and stop reason from the file
    said.textContent = s.warnings.join("\n");
    if (weights === null) weights = (await api(`/api/session?path=${encodeURIComponent(path)}`)).weights || [];
    drawPlot(holder, { blocks: s.blocks, weights });
    if (s.readings_ohm.length) Plot.drawReadings(readingsBox, s.readings_ohm);
    if (s.running) followTimer = setTimeout(poll, 1000);
    else document.getElementById("main").prepend(el("p", { id: "follow-ended" }, `${s.status}: `, el("a", { href: `#/session/${encodeURIComponent(path)}`, text: "the session's page" })));
  };
  poll();
}

// ---- routing -----------------------------------------------------------------------------------------------
function route() {
  if (source) { source.close(); source = null; }
  if (followTimer) { clearTimeout(followTimer); followTimer = null; }
  if (queueTimer) { clearTimeout(queueTimer); queueTimer = null; }
  keys = null;
  const hash = location.hash || "#/sessions";
  const [, page, ...rest] = hash.split("/");
  const arg = decodeURIComponent(rest.join("/"));
  if (page === "new") showNew();
  else if (page === "run") showRun(arg);
  else if (page === "session") showSession(arg);
  else if (page === "follow") showFollow(arg);
  else if (page === "diff") showDiff(arg);
  else if (page === "queue") showQueue();
  else showSessions();
}

window.addEventListener("hashchange", route);
document.addEventListener("DOMContentLoaded", route);
