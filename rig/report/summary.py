"""A run's summary for people: units, the stop in words, each axis's peaks, said to be maxima of the
absolute value (``rig run``, ``rig demo``)."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["PERFORMANCE", "failed_figures", "summary_lines"]

#: a run's performance figures: NaN, never 0, when it did not complete (``failed_figures``)
PERFORMANCE = ("rms_error", "max_error", "chattering_count", "chattering_amplitude", "sign_law_share")


def failed_figures(figures: dict[str, Any], why: str) -> dict[str, Any]:
    """``figures`` of a run that did not complete: each ``PERFORMANCE`` figure NaN (a filter on
    small errors or on no chattering keeps none of them), the chattering note saying ``why``, and
    what they were when it ended under ``cut_short`` (for the post-mortem, not for a verdict).

    Parameters
    ----------
    figures : dict[str, Any]
        The run's figures.
    why : str
        Why it did not complete.

    Returns
    -------
    dict[str, Any]
        The figures for the summary.
    """
    out = {k: (math.nan if k in PERFORMANCE else v) for k, v in figures.items()}
    out["chattering_note"] = f"not measured: {why}"
    out["cut_short"] = {k: figures[k] for k in PERFORMANCE if k in figures}
    return out


#: the unit each axis peak is in
_PEAK_UNITS = {"max_abs_velocity": "rad/s", "max_abs_current": "A", "max_abs_position": "rad"}


def summary_lines(summary: dict[str, Any]) -> list[str]:
    """The summary for a person, with units: the law's figures, the stop in words, each axis's
    peaks as ``max |velocity| 120.4 rad/s`` (``--json`` has the same figures as ``max_abs_*``).

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary.

    Returns
    -------
    list[str]
        The lines.
    """
    unit = summary.get("error_unit", "")
    command_unit = summary.get("command_unit") or "command's unit"
    command_units = summary.get("command_units", {})
    rows = [
        ("cycles", _cycles(summary)),
        ("rms error", _figure(summary, "rms_error", unit)),
        ("max error", _figure(summary, "max_error", unit)),
        ("chattering", _chattering(summary, command_unit)),
        ("sign law", _sign_law(summary)),
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


def _figure(summary: dict[str, Any], key: str, unit: str) -> str:
    """A performance figure with its unit; of a run that did not complete, none, and what it was
    when the run was cut short."""
    value = summary.get(key, math.nan)
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:.4g} {unit}".rstrip()
    before = (summary.get("cut_short") or {}).get(key, math.nan)
    if summary.get("status") == "stopped" and isinstance(before, float) and math.isfinite(before):
        return f"- (the run stopped; {before:.4g} {unit} over its cycles before the stop)".replace(" )", ")")
    return "-"


def _peak_unit(key: str, command_unit: str) -> str:
    """The unit of an axis peak: ``command_unit`` (its mode's) for the command, else ``_PEAK_UNITS``."""
    return command_unit if key == "max_abs_command" else _PEAK_UNITS.get(key, "")


def _chattering(summary: dict[str, Any], unit: str) -> str:
    """The chattering figures in words (docs/chattering.md): the count against the threshold and
    the resolution it came from, or why there is none (``chattering_note``), the RMS increment."""
    amplitude = summary.get("chattering_amplitude", math.nan)
    note = summary.get("chattering_note")
    if not math.isfinite(amplitude):
        return note or "not measured: the run ended before its second half had two commands"
    threshold = summary.get("chattering_threshold", 0.0)
    rms = f"RMS increment {amplitude:.3g} {unit}"
    if note:
        return f"{note}; {rms}"
    res = summary.get("feedback_resolution") or {}
    source = res.get("source", "declared")
    return (
        f"{summary['chattering_count']} sign alternations of the command increment beyond "
        f"{threshold:.3g} {unit} (the effect of one step of the feedback's resolution, "
        f"{res.get('position', 0.0):.3g} rad and {res.get('velocity', 0.0):.3g} rad/s, {source}) in the "
        f"second half, {rms}"
    )


def _sign_law(summary: dict[str, Any]) -> str:
    """The sign-law share in words: the part of the second half's cycles a sliding-mode law spent
    outside its linear region."""
    share = summary.get("sign_law_share", math.nan)
    if summary.get("status") == "stopped":
        return "not measured: the run stopped"
    if not isinstance(share, float) or not math.isfinite(share):
        return "- (not a sliding-mode law, or no second half)"
    return f"{100.0 * share:.3g} % of the second half's cycles outside the law's linear region"


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
