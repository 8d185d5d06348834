"""The study's file, ``SPEC.toml``, loaded into a ``SweepSpec`` and checked once, at load.

::

    [sweep]
    name = "servo-b_m"            # the sweep's folder: <output>/<name>/
    base = "../dc_servo_position.toml"   # a rig run configuration (relative to this file), or
    # scenario = "dismc"          # a paper's pure simulation (rig.sweep.scenarios)
    method = "grid"               # grid (every combination) | random | lhs (Latin hypercube)
    samples = 40                  # random, lhs: how many points
    seed = 1                      # random, lhs: the sampling seed
    repeats = 1                   # each point this many times, seeds noise_seed, noise_seed + 1, ...
    noise_seed = 0                # -> [faults] seed of a configuration, seed of a noisy scenario
    metrics = ["rms_error"]       # default: the run summary's figures (the scenario's)
    timeout = 300.0               # [s] a rig run point longer than this stops safely (an error row)
    keep_runs = false             # keep each point's run directory under <sweep>/runs/
    output = "sweeps"

    [parameters]                  # what varies, by dotted name
    "emulator.params.b_m" = { from = 170.0, to = 2720.0, num = 9, scale = "log" }
    "run.period" = [1e-4, 4e-4, 1e-3]          # values (any TOML values: strings, integers)
    "controller.lam" = { values = [-10.0, -15.0], unit = "1/s" }   # values with the plots' unit

    [fixed]                       # set on every point
    "run.duration" = 2.0

A name is a key of the configuration (``controller.lam``, ``emulator.params.b_m``,
``faults.frame_loss``, ``run.period``; ``axis.NAME.limits.command`` for the [[axis]] named
NAME), or a parameter of the scenario. A range is ``{from, to, num, scale}`` (``num`` for a
grid; ``scale`` "linear" or "log"; ``integer = true`` rounds; ``unit`` for the plots' axes);
random and lhs draw from ranges and pick from value lists. Each value is checked against the base
before anything runs.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError

__all__ = ["METHODS", "Parameter", "SweepSpec", "spec_from_doc"]

METHODS = ("grid", "random", "lhs")
#: the table's own columns: no parameter or metric may take these names
RESERVED = (
    "point",
    "seed",
    "repeat",
    "status",
    "stop_reason",
    "error",
    "elapsed_s",
    "run_s",
    "worker",
    "error_unit",
    "command_unit",
)
#: a rig run's summary figures kept by default (``rig.host.loop.HostLoop.summary``)
RUN_METRICS = (
    "rms_error",
    "max_error",
    "chattering_count",
    "chattering_amplitude",
    "sign_law_share",
    "cycles",
    "overruns",
    "held_cycles",
    "stop_confirmed",
)
#: the summary's keys a metric may name (a dotted name reaches into ``axes`` and ``timing``)
SUMMARY_KEYS = (
    *RUN_METRICS,
    "chattering_threshold",
    "chattering_note",
    "feedback_resolution",
    "error_unit",
    "command_unit",
    "axes",
    "timing",
)
_SWEEP_KEYS = {
    "name": str,
    "base": str,
    "scenario": str,
    "method": str,
    "samples": int,
    "seed": int,
    "repeats": int,
    "noise_seed": int,
    "metrics": list,
    "timeout": float,
    "keep_runs": bool,
    "output": str,
}
_RANGE_KEYS = {"from", "to", "num", "scale", "integer", "unit", "values"}


@dataclass(frozen=True)
class Parameter:
    """A varied parameter: ``values`` (a list), or a range ``low``..``high`` (``num`` points on a
    grid; ``scale`` linear or log; ``integer``: rounded)."""

    name: str  #: its dotted name
    values: tuple[Any, ...] = ()  #: a list of values
    low: float = math.nan  #: a range's lower end
    high: float = math.nan  #: its upper end
    num: int = 0  #: a range's points
    scale: str = "linear"  #: "linear" or "log"
    integer: bool = False  #: values rounded
    unit: str = ""  #: for the plots' axes ("" : ``rig.sweep.plot``'s table of known names)

    @property
    def is_range(self) -> bool:
        return not self.values

    def grid(self) -> tuple[Any, ...]:
        """The values of a grid: the list, or ``num`` points of the range (ends included).

        Returns
        -------
        tuple[Any, ...]
            The values.
        """
        if self.values:
            return self.values
        return tuple(self.at(i / (self.num - 1) if self.num > 1 else 0.0) for i in range(self.num))

    def at(self, q: float) -> Any:
        """The range's value at the fraction ``q`` in [0, 1] of its scale, to 12 significant
        digits (a log grid of 170..2720 has 680, not 680.0000000000003).

        Parameters
        ----------
        q : float
            In [0, 1].

        Returns
        -------
        Any
            The value.
        """
        if self.scale == "log":
            x = math.exp(math.log(self.low) + q * (math.log(self.high) - math.log(self.low)))
        else:
            x = self.low + q * (self.high - self.low)
        return round(x) if self.integer else float(f"{x:.12g}")

    def ends(self) -> tuple[Any, ...]:
        """What to check against the base: every value of a list, both ends of a range.

        Returns
        -------
        tuple[Any, ...]
            The values to check.
        """
        return self.values or (self.at(0.0), self.at(1.0))


@dataclass(frozen=True)
class SweepSpec:
    """A checked study (see the module docstring)."""

    source: str  #: the study's file
    name: str  #: the study's
    base: str = ""  #: the configuration's path ("" : a scenario)
    scenario: str = ""  #: a scenario's name ("": a configuration base)
    method: str = "grid"  #: "grid", "random" or "lhs"
    samples: int = 0  #: points drawn (random, lhs)
    seed: int = 0  #: of the draw
    repeats: int = 1  #: runs per point
    noise_seed: int | None = None  #: the runs' noise seed (None: the base's)
    metrics: tuple[str, ...] = ()  #: the metrics kept
    timeout: float = 300.0  #: [s] a point may run
    keep_runs: bool = False  #: keep each point's run directory
    output: str = "sweeps"  #: the studies' folder
    parameters: tuple[Parameter, ...] = ()  #: the varied parameters
    fixed: dict[str, Any] = field(default_factory=dict)  #: [fixed] values

    @property
    def directory(self) -> Path:
        return Path(self.output) / self.name

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (sweep.json's ``spec``; ``--resume`` compares it).

        Returns
        -------
        dict[str, Any]
            The spec.
        """
        doc = asdict(self)
        doc["parameters"] = [
            {k: v for k, v in asdict(p).items() if not (isinstance(v, float) and math.isnan(v))}
            for p in self.parameters
        ]
        return doc


def _flatten(table: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested tables as dotted names; a range table ({from, to, ...}) is a value."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and not (set(value) & _RANGE_KEYS):
            out.update(_flatten(value, f"{name}."))
        else:
            out[name] = value
    return out


def _parameter(where: str, name: str, value: Any) -> Parameter:
    if isinstance(value, list):
        if not value:
            raise ConfigError(f"{where} {name!r} = []: give at least one value")
        return Parameter(name, values=tuple(value))
    if not isinstance(value, dict):
        raise ConfigError(
            f"{where} {name!r} = {value!r}: expected a list of values or a range "
            "{ from = ..., to = ..., num = ... }"
        )
    unknown = sorted(set(value) - _RANGE_KEYS)
    if unknown:
        raise ConfigError(
            f"{where} {name!r}: unknown key(s) {unknown} in the range; known: {sorted(_RANGE_KEYS)}"
        )
    unit = value.get("unit", "")
    if not isinstance(unit, str):
        raise ConfigError(f"{where} {name!r}: unit = {unit!r}: expected a string")
    if "values" in value:
        others = sorted(set(value) - {"values", "unit"})
        if others or not isinstance(value["values"], list) or not value["values"]:
            raise ConfigError(
                f"{where} {name!r}: {{ values = [...], unit = ... }} takes a list and a unit only"
            )
        return Parameter(name, values=tuple(value["values"]), unit=unit)
    ends = []
    for key in ("from", "to"):
        x = value.get(key)
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            raise ConfigError(f"{where} {name!r}: {key} = {x!r}: expected a finite number")
        ends.append(float(x))
    low, high = ends
    scale, num, integer = value.get("scale", "linear"), value.get("num", 0), value.get("integer", False)
    if scale not in ("linear", "log"):
        raise ConfigError(f"{where} {name!r}: scale = {scale!r}: linear or log")
    if scale == "log" and not (low > 0.0 and high > 0.0):
        raise ConfigError(f"{where} {name!r}: a log scale needs from and to > 0, got {low!r} and {high!r}")
    if isinstance(num, bool) or not isinstance(num, int) or num < 0:
        raise ConfigError(f"{where} {name!r}: num = {num!r}: expected a whole number >= 1")
    if not isinstance(integer, bool):
        raise ConfigError(f"{where} {name!r}: integer = {integer!r}: true or false")
    return Parameter(name, low=low, high=high, num=num, scale=scale, integer=integer, unit=unit)


def _sweep_table(source: str, table: Any) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise ConfigError(f"{source}: [sweep] is missing: give at least name and base or scenario")
    out: dict[str, Any] = {}
    for key, value in table.items():
        kind = _SWEEP_KEYS.get(key)
        if kind is None:
            raise ConfigError(f"{source}: unknown key {key!r} in [sweep]; known: {', '.join(_SWEEP_KEYS)}")
        number = kind is float and isinstance(value, int) and not isinstance(value, bool)
        typed = float(value) if number else value
        if not isinstance(typed, kind) or (kind is int and isinstance(typed, bool)):
            raise ConfigError(f"{source}: [sweep] {key} = {value!r}: expected {kind.__name__}")
        out[key] = typed
    return out


def spec_from_doc(doc: dict[str, Any], source: str) -> SweepSpec:
    """A checked spec from a parsed TOML document (``source`` names it in errors); the values are
    checked against the base by ``rig.sweep.point.check_values`` (``rig.sweep.load.load_spec``
    does both).

    Parameters
    ----------
    doc : dict[str, Any]
        The parsed TOML document.
    source : str
        Named in errors.

    Returns
    -------
    SweepSpec
        The spec.

    Raises
    ------
    ConfigError
        If a key is unknown, of a wrong type or refused.
    """
    unknown = sorted(set(doc) - {"sweep", "parameters", "fixed"})
    if unknown:
        raise ConfigError(f"{source}: unknown section(s) {unknown}; known: [sweep], [parameters], [fixed]")
    s = _sweep_table(source, doc.get("sweep"))
    name, base, scenario, method = _study(s, source)
    samples = _counts(s, method, f"{source}: [sweep]")
    timeout = s.get("timeout", 300.0)
    if not (math.isfinite(timeout) and timeout > 0.0):
        raise ConfigError(f"{source}: [sweep] timeout = {timeout!r}: must be a time > 0 s")
    params = _flatten(_table(source, "parameters", doc.get("parameters", {})))
    if not params:
        raise ConfigError(f"{source}: [parameters] is empty: name at least one parameter to vary")
    parameters = tuple(_parameter(f"{source}: [parameters]", n, v) for n, v in params.items())
    for p in parameters:
        if p.is_range and method == "grid" and p.num < 1:
            raise ConfigError(f"{source}: [parameters] {p.name!r}: a grid's range needs num >= 1")
        if p.is_range and method != "grid" and p.num:
            raise ConfigError(f"{source}: [parameters] {p.name!r}: num is a grid's; {method} draws samples")
    fixed = _flatten(_table(source, "fixed", doc.get("fixed", {})))
    metrics = s.get("metrics", [])
    _names(source, params, fixed, metrics)
    return SweepSpec(
        source=source,
        name=name,
        base=base,
        scenario=scenario,
        method=method,
        samples=samples,
        seed=s.get("seed", 0),
        repeats=s.get("repeats", 1),
        noise_seed=s.get("noise_seed"),
        metrics=tuple(metrics),
        timeout=timeout,
        keep_runs=s.get("keep_runs", False),
        output=s.get("output", "sweeps"),
        parameters=parameters,
        fixed=fixed,
    )


def _study(s: dict[str, Any], source: str) -> tuple[str, str, str, str]:
    """[sweep]'s name, base (absolute) or scenario, and method, checked."""
    w = f"{source}: [sweep]"
    name = s.get("name", "")
    if not name or name in (".", "..") or "/" in name or "\\" in name:
        raise ConfigError(f"{w} name = {name!r}: give a plain name (the sweep's folder under output)")
    base, scenario = s.get("base", ""), s.get("scenario", "")
    if bool(base) == bool(scenario):
        raise ConfigError(f"{w}: give base (a rig run configuration) or scenario (a paper's simulation), one")
    if base:  # absolute: a worker started in another folder finds it, and the files it names
        base = str((Path(source).parent / base).resolve())
    method = s.get("method", "grid")
    if method not in METHODS:
        raise ConfigError(f"{w} method = {method!r}: one of {', '.join(METHODS)}")
    return name, base, scenario, method


def _counts(s: dict[str, Any], method: str, w: str) -> int:
    """[sweep]'s samples (checked against the method), repeats and seeds checked: the samples."""
    samples: int = s.get("samples", 0)
    if method != "grid" and samples < 1:
        raise ConfigError(f"{w} samples = {samples!r}: method {method} needs samples >= 1")
    if method == "grid" and "samples" in s:
        raise ConfigError(f"{w} samples: a grid takes every combination; give method = random or lhs")
    if s.get("repeats", 1) < 1:
        raise ConfigError(f"{w} repeats = {s['repeats']!r}: must be >= 1")
    for key in ("seed", "noise_seed"):
        if s.get(key, 0) < 0:
            raise ConfigError(f"{w} {key} = {s[key]!r}: must be >= 0")
    return samples


def _names(source: str, params: dict[str, Any], fixed: dict[str, Any], metrics: Any) -> None:
    """Each name once: varied or fixed, a parameter or a metric, none a column of the results."""
    both = sorted(set(fixed) & set(params))
    if both:
        raise ConfigError(f"{source}: {both} both varied in [parameters] and set in [fixed]: give each once")
    if not all(isinstance(m, str) and m for m in metrics):
        raise ConfigError(f"{source}: [sweep] metrics = {metrics!r}: expected a list of names")
    if set(params) & set(metrics):
        raise ConfigError(f"{source}: {sorted(set(params) & set(metrics))} both a parameter and a metric")
    for n in (*params, *metrics):
        if n in RESERVED:
            raise ConfigError(
                f"{source}: {n!r} is a column of the results table; "
                "the parameter or metric needs another name"
            )


def _table(source: str, name: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ConfigError(f"{source}: [{name}] must be a table")
    return value
