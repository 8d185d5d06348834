// The live scope: the run's rows from /ws/live (25 updates a second), kept for the longest span
// (30 s), drawn at most once a frame. Pause freezes the picture (rows are still kept); a drag on
// a chart zooms it and pauses; Resume follows the run again. Each axis's state and fault above.

import { axisSeries, chartTitle, el, fmt, makeChart } from "./charts.js";

const KEEP = 30; // [s]
const state = { meta: null, cols: [], plots: [], charts: [], paused: false, dirty: false, last: null,
                updates: 0, since: performance.now(), ws: null, ended: false };

function $(id) { return document.getElementById(id); }

function reset(meta) {
  state.meta = meta;
  state.cols = meta.columns.map(() => []);
  state.plots.forEach((p) => p.destroy());
  state.plots = [];
  const box = $("live-charts");
  box.replaceChildren();
  state.charts = meta.charts.map((chart) => {
    const index = chart.columns.map((name) => meta.columns.findIndex((c) => c.name === name));
    const node = el("div", { class: "chart", "data-axis": chart.axis });
    box.append(node);
    const plot = makeChart(node, {
      title: chartTitle(chart), series: axisSeries(meta, chart), data: [[], ...index.map(() => [])],
      height: 220, sync: "live", onZoom: () => setPaused(true),
    });
    state.plots.push(plot);
    return { chart, index, plot, node };
  });
  $("live-pause").disabled = false;
}

function append(rows) {
  if (!rows.length || !state.meta) return;
  const cols = state.cols;
  for (const row of rows) {
    for (let j = 0; j < cols.length; j++) cols[j].push(j < row.length ? row[j] : null);
  }
  const t = cols[0];
  const tEnd = t[t.length - 1];
  let cut = 0;
  while (cut < t.length && t[cut] < tEnd - KEEP) cut++;
  if (cut > 2000) for (let j = 0; j < cols.length; j++) cols[j].splice(0, cut);
  state.last = tEnd;
  state.dirty = true;
}

function draw() {
  requestAnimationFrame(draw);
  if (!state.dirty || state.paused || !state.meta) return;
  state.dirty = false;
  const span = Number($("live-span").value);
  const t = state.cols[0];
  const tEnd = t[t.length - 1];
  for (const { index, plot, node } of state.charts) {
    plot.setData([t, ...index.map((i) => state.cols[i])], false);
    plot.setScale("x", { min: Math.max(t[0], tEnd - span), max: tEnd });
    node.dataset.points = String(t.length);
    node.dataset.tLast = String(tEnd);
  }
  $("live-status").textContent = `${state.meta.title}  t = ${fmt(tEnd)} s`;
  $("live-status").dataset.t = String(tEnd);
}

function showStates(states) {
  const box = $("live-states");
  box.replaceChildren(...Object.entries(states || {}).map(([axis, s]) =>
    el("span", { class: "state" + (s.fault ? " fault" : ""), "data-axis": axis,
                 text: `${axis}: ${s.state}${s.fault ? " — " + s.fault : ""}` })));
}

function showEnd(summary) {
  state.ended = true;
  const stop = summary && summary.safe_stop_reason;
  const lines = [
    el("strong", { text: stop ? `stopped: ${stop}` : "the run ended" }),
    el("div", { text: `cycles ${summary?.cycles ?? "–"}, overruns ${summary?.overruns ?? "–"}, ` +
                      `RMS error ${fmt(summary?.rms_error)} ${summary?.error_unit || ""}` +
                      (summary?.stop_confirmed === false ? " — stop NOT confirmed" : "") }),
    el("div", { class: "note", text: `run directory: ${summary?.run_dir ?? "?"} (see Runs)` }),
  ];
  $("live-end").replaceChildren(el("div", { class: "end" + (stop ? " bad" : ""), id: "live-summary" }, ...lines));
  $("live-status").textContent = `${state.meta ? state.meta.title : "run"}: ended`;
}

export function setPaused(on) {
  state.paused = on;
  $("live-pause").textContent = on ? "Resume" : "Pause";
  if (!on) state.dirty = true;
}

export function startLive(info) {
  $("live-pause").addEventListener("click", () => setPaused(!state.paused));
  $("live-span").addEventListener("change", () => { state.dirty = true; });
  requestAnimationFrame(draw);
  if (!info.live) {
    $("live-status").textContent = "no run is followed: start one with rig run --view, or rig view RUN_DIR";
    return;
  }
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${scheme}://${location.host}/ws/live`);
  state.ws = ws;
  ws.onmessage = (event) => {
    const msg = JSON.parse(event.data);
    if (msg.type === "hello") {
      if (msg.meta) reset(msg.meta);
      append(msg.rows);
      showStates(msg.states);
      if (msg.summary) showEnd(msg.summary);
    } else if (msg.type === "rows") {
      if (msg.meta) reset(msg.meta);
      if (!state.meta) return;
      append(msg.rows);
      showStates(msg.states);
      state.updates++;
      const now = performance.now();
      if (now - state.since > 1000) {
        $("live-rate").textContent = `${(state.updates * 1000 / (now - state.since)).toFixed(1)} updates/s`;
        $("live-rate").dataset.rate = String(state.updates * 1000 / (now - state.since));
        state.updates = 0;
        state.since = now;
      }
    } else if (msg.type === "end") {
      showEnd(msg.summary);
    }
  };
  ws.onclose = () => {
    if (!state.ended) $("live-status").textContent += " (disconnected)";
  };
}

export function liveState() { return state; }
