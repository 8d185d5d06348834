// The runs: newest first; one run's summary, configuration, plots drawn from its samples, its CAN
// trace filtered by COB-ID a page at a time, and a second run overlaid on one time axis.

import { axisSeries, chartTitle, el, fmt, getJSON, makeChart } from "./charts.js";
import { showBode } from "./studies.js";

let runs = [];
let current = null;

const q = (root, name) => `/api/runs/${encodeURIComponent(root)}/${encodeURIComponent(name)}`;

function when(t) {
  return t ? new Date(t * 1000).toLocaleString() : "";
}

function badge(run) {
  if (run.in_progress) return el("span", { class: "badge live", text: "in progress" });
  if (run.stop_reason) return el("span", { class: "badge bad", text: "stopped" });
  return el("span", { class: "badge ok", text: "done" });
}

export async function loadRuns() {
  runs = await getJSON("/api/runs");
  const list = document.getElementById("run-list");
  list.replaceChildren(...runs.map((r) => el("li", {
    "data-name": r.name, onclick: () => showRun(r),
  }, el("span", { text: r.name }), badge(r),
     el("small", { text: `${when(r.started)} · ${r.cycles ?? "–"} cycles` +
                          (r.stop_reason ? ` · ${r.stop_reason}` : "") }))));
  if (!runs.length) list.append(el("li", { class: "note", text: "no run directory here" }));
  return runs;
}

function summaryTable(summary) {
  const rows = Object.entries(summary || {}).map(([k, v]) => el("tr", {},
    el("th", { text: k }),
    el("td", { class: typeof v === "number" ? "num" : "",
               text: typeof v === "number" ? fmt(v) : typeof v === "object" && v !== null ? JSON.stringify(v) : String(v) })));
  return el("table", { id: "run-summary" }, ...rows);
}

function toColumns(rows, width) {
  const cols = Array.from({ length: width }, () => new Array(rows.length));
  rows.forEach((r, i) => { for (let j = 0; j < width; j++) cols[j][i] = r[j]; });
  return cols;
}

function drawRun(box, meta, samples) {
  const cols = toColumns(samples.rows, samples.columns.length);
  const byName = Object.fromEntries(samples.columns.map((c, i) => [c, i]));
  for (const chart of meta.charts) {
    const node = el("div", { class: "chart run-chart", "data-axis": chart.axis });
    box.append(node);
    makeChart(node, {
      title: chartTitle(chart), series: axisSeries(meta, chart),
      data: [cols[0], ...chart.columns.map((c) => cols[byName[c]] || [])], sync: "run",
    });
    node.dataset.points = String(cols[0].length);
  }
}

async function overlay(box, run, other) {
  box.replaceChildren(el("p", { class: "note", text: "loading…" }));
  const [a, b, metaB] = await Promise.all([
    getJSON(q(run.root, run.name) + "/samples?points=4000"),
    getJSON(q(other.root, other.name) + "/samples?points=4000"),
    getJSON(q(other.root, other.name)),
  ]);
  const meta = current.meta;
  const chart = meta.charts[0];
  const names = chart.shown.filter((c) => a.columns.includes(c) && b.columns.includes(c));
  const ca = toColumns(a.rows, a.columns.length);
  const cb = toColumns(b.rows, b.columns.length);
  const joined = uPlot.join([
    [ca[0], ...names.map((n) => ca[a.columns.indexOf(n)])],
    [cb[0], ...names.map((n) => cb[b.columns.indexOf(n)])],
  ]);
  const unit = (n) => (meta.columns.find((c) => c.name === n) || {}).unit || "";
  const series = [
    ...names.map((n) => ({ label: `${n} (${run.name})`, unit: unit(n) })),
    ...names.map((n, i) => ({ label: `${n} (${other.name})`, unit: unit(n), dash: [6, 4],
                             color: ["#8e44ad", "#c9a227", "#16a2b8", "#e84393"][i % 4] })),
  ];
  const node = el("div", { class: "chart", id: "overlay-chart" });
  box.replaceChildren(node);
  makeChart(node, { title: `${chartTitle(chart)}: ${run.name} and ${metaB.name}`, series, data: joined, sync: "overlay" });
  node.dataset.points = String(joined[0].length);
  node.dataset.runs = `${run.name} ${other.name}`;
}

async function traceView(box, run) {
  const input = el("input", { id: "trace-cob", placeholder: "COB-IDs: 181, 201 or 180-1FF", size: "28" });
  const table = el("div", { class: "scroll" });
  const ids = el("div", { class: "note" });
  const pager = el("span", { class: "note", id: "trace-count" });
  let offset = 0;
  const limit = 200;
  async function load() {
    const cob = encodeURIComponent(input.value.trim());
    try {
      const doc = await getJSON(`${q(run.root, run.name)}/trace?cob=${cob}&offset=${offset}&limit=${limit}`);
      pager.textContent = `${doc.matched} frames match; ${doc.offset + 1}–${doc.offset + doc.frames.length}`;
      pager.dataset.matched = String(doc.matched);
      ids.replaceChildren("seen: ", ...doc.ids.map((x) => el("a", {
        href: "#", "data-cob": x.cob_id.toString(16),
        onclick: (e) => { e.preventDefault(); input.value = x.cob_id.toString(16).toUpperCase(); offset = 0; load(); },
        text: `${x.cob_id.toString(16).toUpperCase().padStart(3, "0")} ${x.name} (${x.frames})  `,
      })));
      table.replaceChildren(el("table", { id: "trace-table" },
        el("tr", {}, ...["time [s]", "COB-ID", "what", "dir", "dlc", "data"].map((h) => el("th", { text: h }))),
        ...doc.frames.map((f) => el("tr", {},
          el("td", { class: "num", text: f.t.toFixed(6) }),
          el("td", { text: f.cob_id.toString(16).toUpperCase().padStart(3, "0") }),
          el("td", { text: f.name }), el("td", { text: f.dir }), el("td", { text: String(f.dlc) }),
          el("td", { text: f.data })))));
    } catch (err) {
      table.replaceChildren(el("p", { class: "error", text: String(err.message || err) }));
    }
  }
  box.append(el("div", { class: "controls" }, input,
    el("button", { text: "Filter", onclick: () => { offset = 0; load(); } }),
    el("button", { text: "◀", onclick: () => { offset = Math.max(0, offset - limit); load(); } }),
    el("button", { text: "▶", onclick: () => { offset += limit; load(); } }), pager), ids, table);
  input.addEventListener("keydown", (e) => { if (e.key === "Enter") { offset = 0; load(); } });
  await load();
}

export async function showRun(run) {
  document.querySelectorAll("#run-list li").forEach((li) => li.classList.toggle("active", li.dataset.name === run.name));
  const box = document.getElementById("run-detail");
  box.replaceChildren(el("p", { class: "note", text: "loading…" }));
  try {
    current = await getJSON(q(run.root, run.name));
    const charts = el("div", { id: "run-charts" });
    const overlayBox = el("div", { id: "overlay" });
    const others = runs.filter((r) => r.name !== run.name || r.root !== run.root);
    const pick = el("select", { id: "overlay-with" }, el("option", { value: "", text: "— another run —" }),
      ...others.map((r, i) => el("option", { value: String(i), text: r.name })));
    pick.addEventListener("change", () => { if (pick.value) overlay(overlayBox, run, others[Number(pick.value)]); });
    box.replaceChildren(
      el("h2", { id: "run-title", text: run.name }),
      el("p", { class: "note", text: `${when(run.started)} · ${current.files.join(", ")}` }),
      el("h3", { text: "Summary" }), summaryTable(current.summary),
      el("details", {}, el("summary", { text: "Configuration (config.json)" }),
        el("pre", { text: JSON.stringify(current.config, null, 2) })),
      el("h3", { text: "Samples" }), charts,
      el("h3", { text: "Overlay" }), el("div", { class: "controls" }, "with ", pick), overlayBox,
    );
    if (current.meta) {
      const samples = await getJSON(q(run.root, run.name) + "/samples?points=4000");
      drawRun(charts, current.meta, samples);
    } else {
      charts.append(el("p", { class: "note", text: "no samples" }));
    }
    if (current.identification) {
      const bode = el("div");
      box.append(el("h3", { text: "Identification" }), bode);
      await showBode(bode, run);
    }
    if (current.trace) {
      const trace = el("div", { id: "trace" });
      box.append(el("h3", { text: `CAN trace (${current.trace})` }), trace);
      await traceView(trace, run);
    }
  } catch (err) {
    box.replaceChildren(el("p", { class: "error", text: String(err.message || err) }));
  }
}
