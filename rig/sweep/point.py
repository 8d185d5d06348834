"""One point of a study, run on a worker: its values applied to the base, then a row of figures.

A configuration base runs as ``rig run --config FILE --emulate`` would (``rig.cli.run``): the
TOML document with the point's values set by dotted name, loaded by ``rig.config.rig_config``,
its limits required, then the steps of ``rig.host.session.run_config`` (a ``Session``) in
lock-step over the real protocol stacks; so a point's figures are those of a lone run with the
same values. The run directory goes to a temporary folder, removed after (no trace, no plot, no
fsync), unless the spec keeps runs (then ``<sweep>/runs/point-NNNNN-...``). A scenario base
is a pure simulation (``rig.sweep.scenarios``).

Nothing a point does ends the sweep: a bad value, an exception, a safe stop or the time-out
is the row's ``error`` (a rig run's time-out is a safe stop at the next 1 % of its cycles) and its
``status``; its performance figures are NaN, never 0, so a filter on small errors or on no
chattering keeps none of them.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
import os
import socket
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from drivers.errors import ConfigError
from rig.sweep.points import Point
from rig.sweep.spec import RUN_METRICS, SUMMARY_KEYS, SweepSpec

__all__ = ["Job", "apply_values", "check_values", "default_metrics", "job_of", "point_config", "run_point"]


@dataclass(frozen=True)
class Job:
    """What a worker needs for one point (pickled to it): the base configuration's TOML document
    and its path (or the scenario's name), the fixed and the point's values, the metrics."""

    point: Point  #: the point
    base_doc: dict[str, Any] | None  #: the base configuration's document (None: a scenario)
    base_source: str  #: its path
    scenario: str  #: the scenario's name ("": a configuration base)
    fixed: dict[str, Any]  #: the study's [fixed] values
    metrics: tuple[str, ...]  #: the metrics to give
    timeout: float  #: [s] a point may run
    runs_dir: str  #: "" : a temporary folder, removed after the point


def job_of(spec: SweepSpec, base_doc: dict[str, Any] | None, point: Point) -> Job:
    """What a worker needs for ``point`` of ``spec``.

    Parameters
    ----------
    spec : SweepSpec
        The study.
    base_doc : dict[str, Any] | None
        The base's document (None: a scenario).
    point : Point
        The point.

    Returns
    -------
    Job
        The job.
    """
    runs = str(spec.directory.resolve() / "runs") if spec.keep_runs else ""
    return Job(point, base_doc, spec.base, spec.scenario, spec.fixed, spec.metrics, spec.timeout, runs)


def apply_values(doc: dict[str, Any], values: dict[str, Any], where: str) -> dict[str, Any]:
    """A copy of the TOML document ``doc`` with each dotted name set (``axis.NAME.KEY``: the
    [[axis]] table named NAME); tables on the way are made. ConfigError naming ``where``.

    Parameters
    ----------
    doc : dict[str, Any]
        A TOML document.
    values : dict[str, Any]
        Dotted name -> value.
    where : str
        Named in errors.

    Returns
    -------
    dict[str, Any]
        The new document.

    Raises
    ------
    ConfigError
        If a name is not of the base (``where`` named).
    """
    out = copy.deepcopy(doc)
    for name, value in values.items():
        keys = name.split(".")
        table: Any = out
        if keys[0] == "axis":
            axes = out.get("axis", [])
            named = [
                a
                for a in axes
                if isinstance(a, dict) and a.get("name") == (keys[1] if len(keys) > 2 else None)
            ]
            if len(keys) < 3 or not named:
                known = ", ".join(repr(a.get("name")) for a in axes if isinstance(a, dict))
                raise ConfigError(f"{where} {name!r}: name an axis as axis.NAME.KEY (the axes: {known})")
            table, keys = named[0], keys[2:]
        for key in keys[:-1]:
            table = table.setdefault(key, {})
            if not isinstance(table, dict):
                raise ConfigError(f"{where} {name!r}: {key} is not a table in the base")
        table[keys[-1]] = value
    return out


def _scenario_values(job: Job) -> dict[str, Any]:
    values = {**job.fixed, **job.point.values}
    if job.point.seed is not None:
        values["seed"] = job.point.seed
    return values


def _config_values(job: Job) -> dict[str, Any]:
    values = {**job.fixed, **job.point.values}
    if job.point.seed is not None:
        values["faults.seed"] = job.point.seed
    return values


def _scenario_point(name: str, values: dict[str, Any], where: str) -> Any:
    """The scenario's typed point; ConfigError naming ``where`` and the value."""
    from rig.config.params import build
    from rig.sweep.scenarios import SCENARIOS

    return build(SCENARIOS[name].schema, values, where)


def _config(job: Job, where: str) -> Any:
    """The point's checked configuration, as ``rig run`` loads one (limits required)."""
    from rig.config import rig_config
    from rig.config.checks import require_limits

    assert job.base_doc is not None
    cfg = rig_config(apply_values(job.base_doc, _config_values(job), where), job.base_source)
    require_limits(cfg)
    return cfg


def point_config(spec: SweepSpec, base_doc: dict[str, Any] | None, point: Point) -> Any:
    """``point``'s checked configuration, as a worker loads it (a configuration base only).

    Parameters
    ----------
    spec : SweepSpec
        The study.
    base_doc : dict[str, Any] | None
        The base's document.
    point : Point
        The point.

    Returns
    -------
    Any
        The configuration.
    """
    return _config(job_of(spec, base_doc, point), f"{spec.source}: point {point.index}:")


def check_values(spec: SweepSpec) -> None:
    """Every list value and both ends of every range, each alone with [fixed] on the base:
    ConfigError naming the spec, the parameter and the value before anything runs.

    Parameters
    ----------
    spec : SweepSpec
        The study.

    Raises
    ------
    ConfigError
        At the first value the base refuses (spec, parameter and value named).
    """
    from rig.sweep.scenarios import SCENARIOS

    if spec.scenario:
        if spec.scenario not in SCENARIOS:
            raise ConfigError(
                f"{spec.source}: [sweep] scenario = {spec.scenario!r}: known: {', '.join(SCENARIOS)}"
            )
        if spec.repeats > 1 and not SCENARIOS[spec.scenario].seeded:
            raise ConfigError(
                f"{spec.source}: [sweep] repeats = {spec.repeats}: scenario {spec.scenario} has no noise, "
                "so its repeats would repeat the same numbers"
            )
    base_doc = read_base(spec)
    metrics = SCENARIOS[spec.scenario].metrics if spec.scenario else SUMMARY_KEYS
    for m in spec.metrics:
        if m.split(".")[0] not in metrics:
            raise ConfigError(
                f"{spec.source}: [sweep] metrics: {m!r} is not a figure of the base; "
                f"known: {', '.join(metrics)}"
            )
    for p in spec.parameters:
        for value in p.ends():
            point = Point(0, {p.name: value}, spec.noise_seed)
            where = f"{spec.source}: [parameters] {p.name} = {value!r}:"
            try:
                job = job_of(spec, base_doc, point)
                if spec.scenario:
                    _scenario_point(spec.scenario, _scenario_values(job), f"{spec.source}: [parameters]")
                else:  # the loader checks the law at the period and the preset's parameters too
                    _config(job, f"{spec.source}: [parameters]")
            except ConfigError as exc:
                raise ConfigError(f"{where} {exc}") from None


def read_base(spec: SweepSpec) -> dict[str, Any] | None:
    """The base configuration's TOML document (None for a scenario), checked as ``rig run``
    would load it."""
    if not spec.base:
        return None
    from drivers.files import read_toml
    from rig.config import rig_config

    doc = read_toml(spec.base, what="rig configuration")
    rig_config(doc, spec.base)
    return doc


def default_metrics(spec: SweepSpec) -> tuple[str, ...]:
    """The metrics of a study that names none: the scenario's, or a run's performance figures.

    Parameters
    ----------
    spec : SweepSpec
        The study.

    Returns
    -------
    tuple[str, ...]
        The metrics.
    """
    from rig.sweep.scenarios import SCENARIOS

    if spec.scenario:
        return SCENARIOS[spec.scenario].metrics if spec.scenario in SCENARIOS else ()
    return RUN_METRICS


def _figure(summary: dict[str, Any], name: str) -> Any:
    value: Any = summary
    for key in name.split("."):
        value = value.get(key) if isinstance(value, dict) else None
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        return float(value)
    return str(value)


class _TimeOut:
    """``run_config``'s progress callback: past the deadline, the safe stop (a StopRequested)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.deadline = time.monotonic() + seconds

    def __call__(self, k: int, n: int) -> None:
        if time.monotonic() > self.deadline:
            from rig.host.signals import StopRequested

            raise StopRequested(f"time-out: the point ran longer than {self.seconds:g} s")


@contextlib.contextmanager
def _run_folder(job: Job) -> Iterator[str]:
    if job.runs_dir:
        yield job.runs_dir
        return
    with tempfile.TemporaryDirectory(prefix="rig-sweep-") as folder:
        yield folder


def _run(job: Job) -> tuple[dict[str, Any], float]:
    """(summary, the run's own seconds) of a configuration point: ``run_config``'s steps, with a
    run directory not kept written without a plot and without fsync (the recorder's switches,
    set on this run's recorder only: a worker may run points in threads)."""
    from rig.host.session import Session

    cfg = _config(job, f"{job.base_source}: point {job.point.index}:")
    kept = bool(job.runs_dir)
    with _run_folder(job) as folder:
        name = f"point-{job.point.index:05d}"
        run = dataclasses.replace(cfg.run, output=folder, name=name, trace=cfg.run.trace and kept)
        with Session(dataclasses.replace(cfg, run=run), emulate=True) as session:
            if not kept:
                session.recorder.PLOT = session.recorder.DURABLE = False
            session.start()
            n, timeout = session.cycles, _TimeOut(job.timeout)
            summary = session.run(lambda k: timeout(k, n))
    return summary, float(summary.get("elapsed_s") or 0.0)


def _failed_metrics(metrics: tuple[str, ...], scenario: str) -> dict[str, Any]:
    """The metrics of a point that raised: a performance figure (every scenario's; a run's
    ``PERFORMANCE``) NaN, never 0 or empty; the others (stop_confirmed, cycles) unknown."""
    from rig.report.summary import PERFORMANCE

    return {m: math.nan if scenario or m in PERFORMANCE else None for m in metrics}


def run_point(job: Job) -> dict[str, Any]:
    """The row of ``job``'s point: its values and seed, its ``status`` ("completed"; "stopped": a
    safe stop, the time-out's too; "error": an exception), each metric (a performance figure NaN
    unless completed), the stop reason and the error (None when it ran to its end), its seconds
    in the worker (``elapsed_s``; ``run_s``: the loop's or the simulation's own) and the worker.

    Parameters
    ----------
    job : Job
        The job.

    Returns
    -------
    dict[str, Any]
        The row.
    """
    start = time.perf_counter()
    p = job.point
    row: dict[str, Any] = {"point": p.index, **p.values, "seed": p.seed, "repeat": p.repeat}
    row.update(_failed_metrics(job.metrics, job.scenario))
    row.update({"status": "error", "stop_reason": None, "error": None, "run_s": math.nan})
    try:
        if job.scenario:
            from rig.sweep.scenarios import SCENARIOS

            values = _scenario_point(job.scenario, _scenario_values(job), f"scenario {job.scenario}:")
            t0 = time.perf_counter()
            summary = SCENARIOS[job.scenario].run(values)
            row["run_s"] = time.perf_counter() - t0
        else:
            summary, row["run_s"] = _run(job)
            reason = summary.get("safe_stop_reason")
            row["stop_reason"] = reason
            row["error_unit"], row["command_unit"] = summary.get("error_unit"), summary.get("command_unit")
            if reason is not None:
                row["error"] = f"safe stop: {reason}"
        row.update({m: _figure(summary, m) for m in job.metrics})
        row["status"] = summary.get("status", "completed")
    except Exception as exc:  # a point's failure is its row, never the sweep's end
        row["error"] = f"{type(exc).__name__}: {exc}"
    row["elapsed_s"] = time.perf_counter() - start
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row
