"""Value ranges of a rig configuration: what a value must be for a run to make sense.

``rig.config`` and ``rig.axis_config`` check names and types; the checks here run on the
typed tables when a file is loaded, before anything is opened: times and periods that are
finite, timeouts that are not negative and fit the objects they are written to, limits that
leave something to run, fault times and rates in range, a run name that stays in the output
folder. Each refusal is one ``ConfigError`` naming the file, the table, the key and the value.

``require_limits`` is apart: ``rig run`` refuses a commanded axis without any limit unless
``--no-limits`` is given.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any

from drivers.errors import ConfigError

__all__ = [
    "MAX_HEARTBEAT",
    "MAX_PERIOD",
    "MIN_PERIOD",
    "check_axis_values",
    "check_bus",
    "check_faults",
    "check_period",
    "check_reference",
    "check_run",
    "check_run_name",
    "require_finite",
    "require_limits",
]

MIN_PERIOD = 1e-5  #: [s] the shortest cycle: a CAN frame alone takes 50 us at 1 Mbit/s
MAX_PERIOD = 10.0  #: [s] the longest cycle a control loop (and an emulated motor) is run at
MAX_HEARTBEAT = 65.535  #: [s] heartbeat times are 16-bit milliseconds (0x1016, 0x1017)
MAX_LATENCY = 0xFFFF_FFFF * 1e-6  #: [s] the drive's command latency 0x2001 is 32-bit microseconds
_INT32 = 0x7FFF_FFFF


def require(ok: bool, where: str, key: str, value: Any, rule: str) -> None:
    """ConfigError ``<where> <key> = <value>: <rule>`` unless ``ok``."""
    if not ok:
        raise ConfigError(f"{where} {key} = {value!r}: {rule}")


def require_finite(where: str, table: Mapping[str, Any], keys: Iterable[str] | None = None) -> None:
    """No number given in ``table`` (of ``keys``, or all), or in a list there, is infinite: a
    limit is left out for none, never written as inf (NaN is the type check's: not a number);
    ConfigError naming the key and value."""
    for key, value in table.items():
        if keys is not None and key not in keys:
            continue
        items = value if isinstance(value, (list, tuple)) else [value]
        flat = [x for v in items for x in (v if isinstance(v, (list, tuple)) else [v])]
        if any(isinstance(x, float) and math.isinf(x) for x in flat):
            require(False, where, key, value, "must be a finite number (leave a limit out for none)")


def _time(where: str, key: str, value: float, high: float = math.inf) -> None:
    """A finite time in 0 .. ``high`` [s]."""
    rule = "must be a time >= 0 s" + (f" and <= {high:g} s" if high < math.inf else "")
    require(math.isfinite(value) and 0.0 <= value <= high, where, key, value, rule)


def check_period(where: str, key: str, period: float) -> None:
    """A cycle period in ``MIN_PERIOD`` .. ``MAX_PERIOD`` [s]."""
    rule = f"must be a period of {MIN_PERIOD:g} .. {MAX_PERIOD:g} s"
    require(MIN_PERIOD <= period <= MAX_PERIOD, where, key, period, rule)


def check_run_name(where: str, name: str) -> None:
    """A run name is a plain file name: its directory ``<output>/<name>-<time>`` stays in output."""
    plain = (
        bool(name)
        and name not in (".", "..")
        and not any(c in "/\\" or ord(c) < 32 or c == "\x7f" for c in name)
        and len(name.encode("utf-8", "replace")) <= 200
    )
    rule = "must be a plain name (no / or \\, no '..', no control characters, at most 200 bytes)"
    require(plain, where, "name", name, rule)


def check_run(src: str, run: Any) -> None:
    """``[run]``: duration, period, name, output."""
    w = f"{src}: [run]"
    d = run.duration
    require(math.isfinite(d) and d > 0.0, w, "duration", d, "must be a finite time > 0 s")
    if run.period != 0.0:
        check_period(w, "period", run.period)
    b = run.answer_budget
    require(
        math.isfinite(b) and b >= 0.0, w, "answer_budget", b, "must be a time >= 0 s (0: half the period)"
    )
    if run.period > 0.0:
        require(b < run.period, w, "answer_budget", b, f"must be shorter than the period {run.period:g} s")
    require(run.late_stop >= 0, w, "late_stop", run.late_stop, "must be >= 0 cycles (0: never)")
    require(
        0 <= run.rt_priority <= 99, w, "rt_priority", run.rt_priority, "must be 0-99 (0: normal scheduling)"
    )
    require(
        run.rt_cpu >= -2,
        w,
        "rt_cpu",
        run.rt_cpu,
        "must be a CPU number, -1 (the last CPU) or -2 (not pinned)",
    )
    check_run_name(w, run.name)
    require(bool(run.output) and "\0" not in run.output, w, "output", run.output, "must be a folder's path")


def check_bus(src: str, bus: Any) -> None:
    """``[bus]``: a python-can interface, heartbeat, bitrate, port."""
    from drivers.bus import check_interface

    w = f"{src}: [bus]"
    check_interface(bus.interface, f"{w} interface =")
    _time(w, "heartbeat", bus.heartbeat, MAX_HEARTBEAT)
    require(bus.bitrate >= 0, w, "bitrate", bus.bitrate, "must be >= 0 bit/s (0: the interface's)")
    require(0 < bus.port < 65536, w, "port", bus.port, "must be 1..65535")


def check_reference(src: str, ref: Any) -> None:
    """``[reference]``: finite numbers, a duration > 0."""
    w = f"{src}: [reference]"
    for key in ("distance", "start", "value"):
        value = getattr(ref, key)
        require(math.isfinite(value), w, key, value, "must be a finite number")
    d = ref.duration
    require(math.isfinite(d) and d > 0.0, w, "duration", d, "must be a finite time > 0 s")


def check_faults(w: str, faults: Any) -> None:
    """``[faults]`` (``w``: the file and table, or the option): a loss rate in [0, 1), times >= 0
    (inf: never), a glitch that fits 32 bits."""
    loss = faults.frame_loss
    require(0.0 <= loss < 1.0, w, "frame_loss", loss, "must be a fraction in [0, 1)")
    require(faults.seed >= 0, w, "seed", faults.seed, "must be >= 0")
    for key in [f.name for f in dataclasses.fields(faults) if f.name.endswith("_at")]:
        value = getattr(faults, key)
        require(value >= 0.0, w, key, value, "must be a time >= 0 s (inf: never)")
    counts = faults.encoder_glitch_counts
    require(abs(counts) <= _INT32, w, "encoder_glitch_counts", counts, f"must be within +-{_INT32}")


def check_axis_values(where: str, a: Any) -> None:
    """An ``[[axis]]`` table's numbers, its units and its limits (``where``: file and axis)."""
    for key in ("enable_timeout", "stop_timeout", "mode_timeout", "sdo_timeout"):
        _time(where, key, getattr(a, key))
    _time(where, "latency", a.latency, MAX_LATENCY)
    _time(where, "host_timeout", a.host_timeout, MAX_HEARTBEAT)
    periods = a.rpdo_deadline_periods
    require(0 <= periods <= 1000, where, "rpdo_deadline_periods", periods, "must be 0..1000 (0: none)")
    _time(where, "rpdo_deadline", a.rpdo_deadline, 60.0)
    require(a.sdo_retries >= -1, where, "sdo_retries", a.sdo_retries, "must be >= 0 (-1: the driver's)")
    require(0 <= a.unit <= 247, where, "unit", a.unit, "must be a Modbus unit id 0..247")
    require(0 < a.port < 65536, where, "port", a.port, "must be 1..65535")
    require(a.baudrate > 0, where, "baudrate", a.baudrate, "must be > 0 bit/s")
    u, wu = a.units, f"{where} units"
    require(0 <= u.counts_per_rev <= _INT32, wu, "counts_per_rev", u.counts_per_rev, f"must be 0..{_INT32}")
    for key in ("rated_torque", "rated_current"):
        value = getattr(u, key)
        require(math.isfinite(value) and value >= 0.0, wu, key, value, "must be a finite number >= 0")
    for key in ("position_unit", "velocity_unit"):
        value = getattr(u, key)
        require(0 <= value <= 0xFFFF_FFFF, wu, key, value, "must be a 32-bit SI unit code (0: the device's)")
    _check_limits(f"{where} limits", a.limits)


def _check_limits(w: str, lim: Any) -> None:
    """Limits that let something run: > 0, a position window min < max, a watchdog, supervision."""
    for key in ("command", "speed", "current"):
        value = getattr(lim, key)
        require(value > 0.0, w, key, value, "must be > 0 (leave it out for no limit)")
    lo, hi = lim.position_min, lim.position_max
    require(lo < hi, w, "position_min", lo, f"must be < position_max = {hi!r}: no position is allowed")
    require(lim.watchdog_periods >= 1, w, "watchdog_periods", lim.watchdog_periods, "must be >= 1")
    _time(w, "watchdog", lim.watchdog)  # real time: at least this long
    rest = lim.rest_speed
    require(math.isfinite(rest) and rest > 0.0, w, "rest_speed", rest, "must be a speed > 0 rad/s")
    _time(w, "rest_time", lim.rest_time, 60.0)
    hb = lim.heartbeat_timeout
    # the drive's heartbeat 0x1017 is set to a third of it, in 16-bit milliseconds
    _time(w, "heartbeat_timeout", hb, 3 * MAX_HEARTBEAT)


def require_limits(cfg: Any) -> None:
    """Refuse a commanded axis (by the law or a profile) without any limit (``rig run --no-limits``)."""
    commanded = {*cfg.controller.commands, *(a.name for a in cfg.axes if a.profile)}
    bare = [
        a.name
        for a in cfg.axes
        if a.name in commanded
        and all(math.isinf(getattr(a.limits, k)) for k in ("command", "speed", "current"))
        and math.isinf(a.limits.position_min)
        and math.isinf(a.limits.position_max)
    ]
    if bare:
        raise ConfigError(
            f"{cfg.source}: [[axis]] {', '.join(map(repr, bare))}: commanded without any limit: "
            "give [axis.limits] command, speed, position_min/max or current (or rig run --no-limits)"
        )
