"""A run's summary for people: units, the stop in words, each axis's peaks, said to be maxima of the
absolute value (``rig run``, ``rig demo``)."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["summary_lines"]

#: the unit each axis peak is in
_PEAK_UNITS = {"max_abs_velocity": "rad/s", "max_abs_current": "A", "max_abs_position": "rad"}


def summary_lines(summary: dict[str, Any]) -> list[str]:
    """The summary for a person, with units: the law's figures, the stop in words, each axis's
    peaks as ``max |velocity| 120.4 rad/s`` (``--json`` has the same figures as ``max_abs_*``)."""
    unit = summary.get("error_unit", "")
    command_unit = summary.get("command_unit") or "command's unit"
    command_units = summary.get("command_units", {})
    rows = [
        ("cycles", _cycles(summary)),
        ("rms error", f"{summary['rms_error']:.4g} {unit}".rstrip()),
        ("max error", f"{summary['max_error']:.4g} {unit}".rstrip()),
        ("chattering", _chattering(summary, command_unit)),
        ("stop", summary["safe_stop_reason"] or "none: the run ended at its duration, every axis stopped"),
        ("stop confirmed", _confirmed(summary)),
        ("run directory", summary["run_dir"]),
    ]
    if summary.get("files_not_written"):
        lost = summary.get("samples_not_written") or 0
        files = ", ".join(summary["files_not_written"])
        rows.append(("NOT WRITTEN", files + (f"; {lost} samples" if lost else "")))
    lines = [f"{key:15s} {text}" for key, text in rows]
    for name, peaks in summary.get("axes", {}).items():
        unit = command_units.get(name, "")
        said = [
            f"max |{k.removeprefix('max_abs_')}| {v:.4g} {_peak_unit(k, unit)}".rstrip()
            for k, v in peaks.items()
        ]
        lines.append(f"axis {name:10s} " + ", ".join(said))
    return lines


def _cycles(summary: dict[str, Any]) -> str:
    """Cycles run and skipped; in real time, the skipped and late ones as shares of the cycles
    the run was to have (a run that missed its period says so: ``rig.host.loop_summary``)."""
    run, skipped = summary["cycles"], summary.get("overruns") or 0
    if summary.get("realtime") is None:
        return f"{run} run, {skipped or 'none'} skipped"
    late = summary.get("late_cycles") or 0
    total = max(1, run + skipped)
    return (
        f"{run} run, {skipped} skipped ({100.0 * skipped / total:.2g} %), "
        f"{late} late ({100.0 * late / total:.2g} %)"
    )


def _peak_unit(key: str, command_unit: str) -> str:
    """The unit of an axis peak: ``command_unit`` (its mode's) for the command, else ``_PEAK_UNITS``."""
    return command_unit if key == "max_abs_command" else _PEAK_UNITS.get(key, "")


def _chattering(summary: dict[str, Any], unit: str) -> str:
    """The chattering figures in words; a run that ended before two commands of its second half
    has none (its amplitude is NaN), and a count is not measurable where one count's effect
    covers the command's range (``chattering_count`` None)."""
    amplitude = summary.get("chattering_amplitude", math.nan)
    if not math.isfinite(amplitude):
        return "not measured: the run ended before its second half had two commands"
    if summary["chattering_count"] is None:
        return (
            f"not measurable: one count's effect ({summary['chattering_threshold']:.3g} {unit}) is at "
            f"least the command's whole range, so no increment can exceed it; RMS increment "
            f"{amplitude:.3g} {unit}"
        )
    return (
        f"{summary['chattering_count']} sign alternations of the command increment beyond one "
        f"count's effect ({summary.get('chattering_threshold', 0.0):.3g} {unit}) in the second "
        f"half, RMS increment {amplitude:.3g} {unit}"
    )


def _confirmed(summary: dict[str, Any]) -> str:
    """The stop's confirmation in words, with the axes still turning after it and their speeds."""
    confirmed = summary["stop_confirmed"]
    if confirmed is None:
        return "-"
    if confirmed:
        return "yes"
    turning = summary.get("still_turning") or {}
    if not turning:
        return "NO: an axis may still be moving, or a drive faulted during the stop (see the log)"
    said = ", ".join(
        f"{name} at {speed:.4g} rad/s" if speed is not None else f"{name} (no speed sample)"
        for name, speed in turning.items()
    )
    return f"NO: still turning after the disable: {said}"
