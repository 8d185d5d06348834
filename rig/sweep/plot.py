"""``rig sweep --plot DIR``: each metric over one or two varied parameters.

- one varied parameter, or a list-valued parameter (a controller, a law) and one other: a line
  per value of the list, the metric over the other parameter (repeats: each seed's point and
  their mean);
- two numeric parameters on a grid: a heatmap (the mean over repeats and any other parameter);
  sampled (random, lhs): a scatter coloured by the metric.

A point that failed (its status not "completed": a safe stop, a time-out, an error) has NaN for
its performance figures: it is left out of the lines and the cells and drawn as a red x (at the
foot of a line plot, in its cell of a heatmap). A true/false metric
(stop_confirmed) is 1/0. A parameter's axis is logarithmic where its scale is, or where its
values (a list) span a decade or more; a metric's where its values span more than two decades.
Where a study of the position servo varies the plant's b_m, the b_m at which (7.30) becomes
unstable in its linear mode (``rig.sweep.edges``) is drawn: a dashed line, or a dashed curve over
the heatmap's other parameter. Axes carry units: a parameter's
``unit`` in the spec, else ``UNITS`` by its last name; a rig
run's error and command metrics are in the base's units (the summary's error_unit and
command_unit, kept in sweep.json). Matplotlib's Figure, without pyplot.
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

from rig.sweep.spec import Parameter, SweepSpec

__all__ = ["UNITS", "figure", "plot_results"]

#: the stability edge b_m for each combination of the other varied parameters (``rig.sweep.edges``)
Edges = dict[tuple[tuple[str, Any], ...], float]

#: units of the parameters and metrics sweeps name most, by their last dotted part
UNITS = {
    "period": "s",
    "duration": "s",
    "a_m": "1/s",
    "b_m": "rad/(V s^2)",
    "lam": "1/s",
    "frame_loss": "-",
    "counts_per_rev": "counts/rev",
    "latency": "s",
    "Ts": "s",
    "u_bound": "-",
    "L_error": "-",
    "L1": "H",
    "R1": "Ohm",
    "ratio": "-",
    "gamma": "-",
    "chattering_count": "alternations",
    "sign_law_share": "share of the cycles",
    "cycles": "-",
    "overruns": "cycles",
    "held_cycles": "cycles",
    "rise_time_s": "s",
    "settling_time_s": "s",
    "peak_id": "per unit of the q step",
    "overshoot_percent": "%",
    "rise_samples": "samples",
    "settling_samples": "samples",
    "u_min": "-",
    "u_max": "-",
}


def _unit(name: str, units: dict[str, str]) -> str:
    return units.get(name) or UNITS.get(name.rsplit(".", maxsplit=1)[-1], "")


def _label(name: str, units: dict[str, str]) -> str:
    unit = _unit(name, units)
    return f"{name} [{unit}]" if unit else name


def _number(v: Any) -> float:
    """A cell as a number: true/false as 1/0, anything else not a number as NaN."""
    return float(v) if isinstance(v, (int, float)) else math.nan


def _failed(row: dict[str, Any]) -> bool:
    """The point did not complete (a safe stop, its time-out, an exception): its performance
    figures are NaN (``rig.sweep.point``)."""
    return row.get("error") is not None or row.get("status", "completed") != "completed"


#: what a failed point's marker says
FAILED = "failed: stopped or an error (its status and error in the table)"


def _log_axis(p: Parameter) -> bool:
    """A parameter's axis is logarithmic: its scale, or a list of values > 0 over a decade or more."""
    if p.scale == "log":
        return True
    values = [_number(v) for v in p.values]
    return bool(values) and _spans_decades(values, 1.0, strict=False)


def _units(spec: SweepSpec, rows: list[dict[str, Any]]) -> dict[str, str]:
    from rig.sweep.scenarios import SCENARIOS

    units = {p.name: p.unit for p in spec.parameters if p.unit}
    if spec.scenario:
        units |= SCENARIOS[spec.scenario].units
    else:  # a rig run's figures are in its axes' units
        error = next((r.get("error_unit") for r in rows if r.get("error_unit")), None)
        command = next((r.get("command_unit") for r in rows if r.get("command_unit")), None)
        for m in ("rms_error", "max_error"):
            units.setdefault(m, error or "")
        units.setdefault("chattering_amplitude", command or "")
    for m in spec.metrics:
        if any(isinstance(r.get(m), bool) for r in rows):
            units.setdefault(m, "1 = true, 0 = false")
    return {k: v for k, v in units.items() if v}


def plot_results(spec: SweepSpec, rows: list[dict[str, Any]], directory: str) -> list[Path]:
    """One PNG per metric in ``directory`` (made if missing); their paths.

    Parameters
    ----------
    spec : SweepSpec
        The study.
    rows : list[dict[str, Any]]
        Its rows.
    directory : str
        Where the PNGs go.

    Returns
    -------
    list[Path]
        Their paths.
    """
    from rig.sweep.edges import b_m_edges

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    edges = b_m_edges(spec, rows)  # once for every metric's plot
    for metric in spec.metrics:
        path = out / f"{spec.name}-{metric.replace('.', '_')}.png"
        figure(spec, rows, metric, edges).savefig(path)
        paths.append(path)
    return paths


def figure(spec: SweepSpec, rows: list[dict[str, Any]], metric: str, edges: Edges | None = None) -> Any:
    """The matplotlib Figure of ``metric`` over the varied parameters (see the module docstring);
    ``edges``: ``rig.sweep.edges.b_m_edges`` of the rows (None: computed here).

    Parameters
    ----------
    spec : SweepSpec
        The study.
    rows : list[dict[str, Any]]
        Its rows.
    metric : str
        The metric drawn.
    edges : Edges | None, optional
        ``b_m_edges`` of the rows (None: computed here).

    Returns
    -------
    Any
        The Figure.
    """
    from matplotlib.figure import Figure

    from rig.sweep.edges import b_m_edges

    if edges is None:
        edges = b_m_edges(spec, rows)

    units = _units(spec, rows)
    lists = [
        p for p in spec.parameters if p.values and not all(isinstance(v, (int, float)) for v in p.values)
    ]
    numeric = [p for p in spec.parameters if p not in lists]
    fig = Figure(figsize=(7, 5))
    ax = fig.subplots()
    if len(numeric) >= 2 and not lists:
        drawn = _stability_edge(ax, edges, numeric[0], numeric[1])  # first: the failed points' x last
        _heat(fig, ax, rows, numeric[0], numeric[1], metric, units, spec.method == "grid")
    else:
        x = numeric[0] if numeric else spec.parameters[0]
        group = lists[0] if lists and lists[0] is not x else None
        drawn = _stability_edge(ax, edges, x, None)
        _lines(ax, rows, x, group, metric, units)
    if drawn:
        ax.legend(fontsize="small")
    ax.set_title(f"{spec.name}: {metric}")
    fig.tight_layout()
    return fig


def _lines(  # noqa: PLR0917 - one figure's parts
    ax: Any,
    rows: list[dict[str, Any]],
    x: Parameter,
    group: Parameter | None,
    metric: str,
    units: dict[str, str],
) -> None:
    by: dict[Any, dict[float, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        if not _failed(r):
            by[r.get(group.name) if group else None][_number(r.get(x.name))].append(_number(r.get(metric)))
    for key, points in by.items():
        xs = sorted(points)
        means = [sum(points[v]) / len(points[v]) for v in xs]
        line = ax.plot(xs, means, marker="o", label=f"{group.name} = {key}" if group else "mean")[0]
        if any(len(points[v]) > 1 for v in xs):
            every = [(v, y) for v in xs for y in points[v]]
            ax.plot([v for v, _ in every], [y for _, y in every], ".", color=line.get_color(), alpha=0.4)
    failed = [_number(r.get(x.name)) for r in rows if _failed(r)]
    if failed:  # at the foot of the axes, whatever their scale: its figures are NaN
        foot = [0.03] * len(failed)
        ax.plot(failed, foot, "x", color="red", ms=9, mew=2, transform=ax.get_xaxis_transform(), label=FAILED)
    if _log_axis(x):
        ax.set_xscale("log")
    if _spans_decades([y for points in by.values() for ys in points.values() for y in ys]):
        ax.set_yscale("log")
    ax.set_xlabel(_label(x.name, units))
    ax.set_ylabel(_label(metric, units))
    ax.grid(True, which="both", alpha=0.4)
    if group is not None or len(by) > 1 or failed:
        ax.legend(fontsize="small")


def _heat(  # noqa: PLR0917 - one figure's parts
    fig: Any,
    ax: Any,
    rows: list[dict[str, Any]],
    x: Parameter,
    y: Parameter,
    metric: str,
    units: dict[str, str],
    grid: bool,
) -> None:
    if grid:
        xs, ys = sorted({_number(v) for v in x.grid()}), sorted({_number(v) for v in y.grid()})
        cells: dict[tuple[float, float], list[float]] = defaultdict(list)
        for r in rows:
            if not _failed(r):
                cells[(_number(r.get(x.name)), _number(r.get(y.name)))].append(_number(r.get(metric)))
        z = [[_mean(cells.get((a, b), [])) for a in xs] for b in ys]
        norm = _norm([v for row in z for v in row])
        edges = _edges(xs, _log_axis(x)), _edges(ys, _log_axis(y))
        mesh = ax.pcolormesh(*edges, z, shading="flat", norm=norm)
    else:
        done = [r for r in rows if not _failed(r)]
        values = [_number(r.get(metric)) for r in done]
        xy = [_number(r.get(x.name)) for r in done], [_number(r.get(y.name)) for r in done]
        ax.scatter(*xy, facecolors="none", edgecolors="grey")  # where the metric is NaN: the point still
        mesh = ax.scatter(*xy, c=values, norm=_norm(values))
    failed = [r for r in rows if _failed(r)]
    if failed:
        xy = [_number(r.get(x.name)) for r in failed], [_number(r.get(y.name)) for r in failed]
        ax.plot(*xy, "x", color="red", ms=9, mew=2, label=FAILED)
        ax.legend(fontsize="small")
    for axis, p in (("x", x), ("y", y)):
        if _log_axis(p):
            getattr(ax, f"set_{axis}scale")("log")
    ax.set_xlabel(_label(x.name, units))
    ax.set_ylabel(_label(y.name, units))
    fig.colorbar(mesh, ax=ax, label=_label(metric, units))


#: what the drawn stability edge is
EDGE = "(7.30) unstable from here in its linear mode (closed-loop eigenvalues)"


def _stability_edge(ax: Any, edges: Edges, x: Parameter, y: Parameter | None) -> bool:
    """The stability ``edges`` (``rig.sweep.edges``) where the study varies b_m on an axis: a
    dashed vertical line on a line plot (one per value of the other parameters), a dashed curve
    over the other axis of a heatmap; whether it drew one."""
    from rig.sweep.edges import B_M

    if not edges or B_M not in (x.name, None if y is None else y.name):
        return False
    if y is None:
        for i, (key, edge) in enumerate(sorted(edges.items(), key=lambda kv: kv[1])):
            said = ", ".join(f"{n} = {v}" for n, v in key)
            label = f"{EDGE}: b_m = {edge:.4g}" + (f" ({said})" if said else "")
            ax.axvline(edge, ls="--", color=f"C{i + 1}" if len(edges) > 1 else "black", label=label)
        return True
    other = y if x.name == B_M else x
    if any(len(key) != 1 or key[0][0] != other.name for key in edges):
        return False  # the edge also depends on a parameter the plot does not show
    line = sorted((_number(key[0][1]), edge) for key, edge in edges.items())
    at, values = [v for v, _ in line], [e for _, e in line]
    xs, ys = (values, at) if x.name == B_M else (at, values)
    ax.plot(xs, ys, "--o", color="white", mec="black", label=EDGE, zorder=3)
    return True


def _spans_decades(values: list[float], decades: float = 2.0, *, strict: bool = True) -> bool:
    """True when the finite values are all > 0 and span more than (``strict``; else at least)
    ``decades`` decades: a log axis shows them (an error of 0.1 beside one of 100)."""
    finite = [v for v in values if math.isfinite(v)]
    if not finite or min(finite) <= 0.0:
        return False
    span = math.log10(max(finite) / min(finite))
    return span > decades if strict else span >= decades


def _norm(values: list[float]) -> Any:
    """A logarithmic colour scale where ``_spans_decades``, else matplotlib's linear one."""
    if not _spans_decades(values):
        return None
    from matplotlib.colors import LogNorm

    finite = [v for v in values if math.isfinite(v)]
    return LogNorm(min(finite), max(finite))


def _mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else math.nan


def _edges(values: list[float], log: bool) -> list[float]:
    """Cell edges around sorted centres (geometric midpoints on a log axis)."""
    if len(values) == 1:
        v = values[0]
        return [v * 0.9, v * 1.1] if log else [v - 0.5, v + 0.5]
    if log:
        mids = [math.sqrt(a * b) for a, b in itertools.pairwise(values)]
        return [values[0] ** 2 / mids[0], *mids, values[-1] ** 2 / mids[-1]]
    mids = [(a + b) / 2 for a, b in itertools.pairwise(values)]
    return [2 * values[0] - mids[0], *mids, 2 * values[-1] - mids[-1]]
