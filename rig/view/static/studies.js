// Studies (rig sweep): the results table (a click on a heading sorts by it; failed points marked)
// and a metric over a varied parameter (one series per value of a second one). Identifications
// (rig identify): the Bode plot of the measured response with the fitted model, and the coherence.

import { el, fmt, getJSON, makeChart } from "./charts.js";

const q = (kind, root, name) => `/api/${kind}/${encodeURIComponent(root)}/${encodeURIComponent(name)}`;

export async function loadStudies(runs) {
  const studies = await getJSON("/api/studies");
  const list = document.getElementById("study-list");
  list.replaceChildren(...studies.map((s) => el("li", { "data-name": s.name, onclick: () => showStudy(s) },
    el("span", { text: s.name }),
    el("small", { text: `${s.status || ""} · ${s.counts ? `${s.counts.done}/${s.counts.points} points, ${s.counts.failed} failed` : ""}` }))));
  if (!studies.length) list.append(el("li", { class: "note", text: "no study here" }));
  const idents = runs.filter((r) => r.identification);
  const ilist = document.getElementById("ident-list");
  ilist.replaceChildren(...idents.map((r) => el("li", { "data-name": r.name, onclick: () => {
    const box = document.getElementById("study-detail");
    box.replaceChildren(el("h2", { text: r.name }));
    const bode = el("div");
    box.append(bode);
    showBode(bode, r);
  } }, el("span", { text: r.name }))));
  if (!idents.length) ilist.append(el("li", { class: "note", text: "no identification here" }));
}

function cell(v) {
  if (typeof v === "number") return el("td", { class: "num", text: fmt(v) });
  if (v === null || v === undefined) return el("td", { text: "" });
  return el("td", { text: typeof v === "object" ? JSON.stringify(v) : String(v) });
}

function compare(a, b) {
  if (a == null && b == null) return 0;
  if (a == null) return 1;
  if (b == null) return -1;
  if (typeof a === "number" && typeof b === "number") return a - b;
  return String(a).localeCompare(String(b), undefined, { numeric: true });
}

function sweepTable(doc) {
  const rows = doc.rows.slice();
  const first = ["point", ...doc.parameters, ...doc.metrics];
  const rest = [...new Set(rows.flatMap((r) => Object.keys(r)))].filter((k) => !first.includes(k));
  const keys = [...first, ...rest.filter((k) => ["stop_reason", "error", "seed", "repeat"].includes(k))];
  const table = el("table", { id: "sweep-table" });
  const head = el("tr", {}, ...keys.map((k) => el("th", { class: "sortable", "data-key": k,
    text: doc.units[k] ? `${k} [${doc.units[k]}]` : k })));
  const body = el("tbody");
  function render() {
    body.replaceChildren(...rows.map((r) => el("tr", { class: r.error != null ? "failed" : "", "data-point": String(r.point) },
      ...keys.map((k) => cell(r[k])))));
  }
  head.addEventListener("click", (e) => {
    const th = e.target.closest("th");
    if (!th) return;
    const dir = th.dataset.dir === "asc" ? "desc" : "asc";
    head.querySelectorAll("th").forEach((h) => h.removeAttribute("data-dir"));
    th.dataset.dir = dir;
    const k = th.dataset.key;
    rows.sort((a, b) => {  // a point without the value (a failed one) last, either way
      if (a[k] == null || b[k] == null) return (a[k] == null) - (b[k] == null);
      return (dir === "asc" ? 1 : -1) * compare(a[k], b[k]);
    });
    render();
  });
  table.append(el("thead", {}, head), body);
  render();
  return table;
}

function metricChart(box, doc) {
  const metric = el("select", { id: "sweep-metric" }, ...doc.metrics.map((m) => el("option", { value: m, text: m })));
  const over = el("select", { id: "sweep-over" }, ...doc.parameters.map((p) => el("option", { value: p, text: p })));
  const node = el("div", { class: "chart", id: "sweep-chart" });
  const params = (doc.sweep.spec && doc.sweep.spec.parameters) || [];
  function draw() {
    node.replaceChildren();
    const x = over.value;
    const m = metric.value;
    const other = doc.parameters.find((p) => p !== x);
    const ok = doc.rows.filter((r) => r.error == null && typeof r[x] === "number");
    const groups = other ? [...new Set(ok.map((r) => r[other]))].sort(compare).slice(0, 10) : [null];
    const xs = [...new Set(ok.map((r) => r[x]))].sort((a, b) => a - b);
    const data = [xs, ...groups.map((g) => xs.map((v) => {
      const hit = ok.find((r) => r[x] === v && (g === null || r[other] === g));
      return hit && typeof hit[m] === "number" ? hit[m] : null;
    }))];
    const log = (params.find((p) => p.name === x) || {}).scale === "log";
    makeChart(node, {
      title: `${m} over ${x}`, xLabel: doc.units[x] ? `${x} [${doc.units[x]}]` : x, xLog: log, points: true,
      series: groups.map((g) => ({ label: g === null ? m : `${other} = ${fmt(g)}`, unit: "" })),
      data, sync: "sweep",
    });
    node.dataset.points = String(xs.length);
  }
  metric.addEventListener("change", draw);
  over.addEventListener("change", draw);
  box.append(el("div", { class: "controls" }, "metric ", metric, " over ", over), node);
  if (doc.metrics.length && doc.parameters.length) draw();
}

export async function showStudy(study) {
  document.querySelectorAll("#study-list li, #ident-list li").forEach((li) => li.classList.toggle("active", li.dataset.name === study.name));
  const box = document.getElementById("study-detail");
  box.replaceChildren(el("p", { class: "note", text: "loading…" }));
  try {
    const doc = await getJSON(q("studies", study.root, study.name));
    const failed = doc.rows.filter((r) => r.error != null).length;
    box.replaceChildren(
      el("h2", { id: "study-title", text: study.name }),
      el("p", { class: "note", text: `${doc.rows.length} points, ${failed} failed; varied: ${doc.parameters.join(", ")}` }),
    );
    if (doc.problem) box.append(el("p", { class: "error", text: doc.problem }));
    metricChart(box, doc);
    box.append(el("h3", { text: "Results" }), el("div", { class: "scroll" }, sweepTable(doc)));
  } catch (err) {
    box.replaceChildren(el("p", { class: "error", text: String(err.message || err) }));
  }
}

export async function showBode(box, run) {
  const doc = await getJSON(q("runs", run.root, run.name) + "/identification");
  const fr = doc.frequency_response;
  box.append(el("p", { id: "ident-model", text:
    `a_m = ${fmt(doc.a_m)} 1/s, b_m = ${fmt(doc.b_m)} ${doc.b_m_unit || ""}, delay ${fmt(doc.delay)} s, ` +
    `held-out fit ${fmt(doc.fit_percent)} %` }));
  for (const w of doc.warnings || []) box.append(el("p", { class: "error", text: w }));
  if (!fr) {
    box.append(el("p", { class: "note", text: "no frequency response (a step or PRBS experiment)" }));
    return;
  }
  const f = fr.frequency;
  const mag = el("div", { class: "chart", id: "bode-magnitude" });
  const phase = el("div", { class: "chart", id: "bode-phase" });
  const coh = el("div", { class: "chart", id: "bode-coherence" });
  box.append(mag, phase, coh);
  const xLabel = "frequency [Hz]";
  makeChart(mag, { title: "speed / input: magnitude", xLabel, xLog: true, sync: "bode", height: 200,
    series: [{ label: "measured", unit: "dB" }, { label: "model", unit: "dB", dash: [6, 4] }],
    data: [f, fr.magnitude_db, fr.model_magnitude_db] });
  makeChart(phase, { title: "phase", xLabel, xLog: true, sync: "bode", height: 200,
    series: [{ label: "measured", unit: "deg" }, { label: "model", unit: "deg", dash: [6, 4] }],
    data: [f, fr.phase_deg, fr.model_phase_deg] });
  makeChart(coh, { title: `coherence (trusted above ${fr.coherence_min})`, xLabel, xLog: true, sync: "bode", height: 160,
    series: [{ label: "coherence", unit: "" }, { label: "threshold", unit: "", dash: [3, 3] }],
    data: [f, fr.coherence, f.map(() => fr.coherence_min)] });
  mag.dataset.points = String(f.length);
}
