// Charts of drive-rig's view, drawn with uPlot (third_party/uplot, MIT): one chart per axis,
// its columns as series (a click on a legend entry shows or hides one), a y axis per unit
// (the first two drawn, left and right), the cursor's values with their units in the legend,
// drag to zoom the time axis, double-click to zoom out. The cursors of charts of one group move
// together.

const PALETTE = ["#2f5fd0", "#d0582f", "#2b9348", "#8e44ad", "#c9a227", "#16a2b8", "#7f8c8d", "#e84393"];

export function fmt(v) {
  if (v == null || Number.isNaN(v)) return "–";
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(3);
  return v.toPrecision(5).replace(/\.?0+$/, "");
}

export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "class") node.className = v;
    else if (k === "text") node.textContent = v;
    else if (k.startsWith("on")) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v);
  }
  for (const c of children) node.append(c);
  return node;
}

export async function getJSON(url) {
  const r = await fetch(url, { credentials: "same-origin" });
  const doc = await r.json().catch(() => ({ error: `${r.status} ${r.statusText}` }));
  if (!r.ok) throw new Error(doc.error || `${r.status}`);
  return doc;
}

function width(node) {
  return Math.max(320, (node.clientWidth || node.parentElement?.clientWidth || 900) - 10);
}

// series: [{label, unit, show, dash, color}]; returns a uPlot over data [x, ...ys]
export function makeChart(node, { title, series, data, xLabel = "time [s]", xLog = false, height = 240,
                                  sync = "rig", onZoom = null, points = false }) {
  // the units of the series shown first: their axes are the ones drawn
  const units = [...new Set([...series.filter((s) => s.show !== false), ...series].map((s) => s.unit || ""))];
  const scales = { x: xLog ? { time: false, distr: 3 } : { time: false } };
  units.forEach((u) => { scales[u || "-"] = { auto: true }; });
  const axes = [{ label: xLabel }];
  units.slice(0, 2).forEach((u, i) => {
    axes.push({ scale: u || "-", label: u ? `[${u}]` : "", side: i === 0 ? 3 : 1, grid: { show: i === 0 } });
  });
  const opts = {
    title, width: width(node), height,
    scales, axes,
    cursor: { sync: { key: sync }, drag: { x: true, y: false } },
    legend: { live: true },
    series: [
      { label: xLabel.replace(/ \[.*\]/, ""), value: (u, v) => (v == null ? "–" : `${fmt(v)} ${xLabel.includes("[s]") ? "s" : "Hz"}`) },
      ...series.map((s, i) => ({
        label: s.label,
        scale: s.unit || "-",
        show: s.show !== false,
        stroke: s.color || PALETTE[i % PALETTE.length],
        dash: s.dash,
        width: 1.25,
        spanGaps: false,
        points: points ? { show: true, size: 6 } : { show: false },
        paths: points ? () => null : undefined,
        value: (u, v) => (v == null ? "–" : `${fmt(v)}${s.unit ? " " + s.unit : ""}`),
      })),
    ],
    hooks: onZoom ? { setSelect: [(u) => { if (u.select.width > 0) onZoom(u); }] } : {},
  };
  const plot = new uPlot(opts, data, node);
  plot.root.dataset.points = String(data[0]?.length || 0);
  return plot;
}

export function columnUnit(meta, name) {
  const c = meta.columns.find((x) => x.name === name);
  return c ? c.unit : "";
}

// the chart of one axis of a run (meta from the server): its columns as series, shown as meta says
export function axisSeries(meta, chart, suffix = "", dash) {
  return chart.columns.map((name) => ({
    label: suffix ? `${name} ${suffix}` : name,
    unit: columnUnit(meta, name),
    show: chart.shown.includes(name),
    dash,
  }));
}

export function chartTitle(chart) {
  return chart.mode ? `${chart.axis} (${chart.mode})` : chart.axis;
}

export function resizeAll(plots) {
  for (const p of plots) p.setSize({ width: width(p.root.parentElement), height: p.height });
}
