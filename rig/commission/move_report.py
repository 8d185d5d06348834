"""A ``rig drive`` move's report in words for a person (``report_lines``): what was asked, where
the shaft ended in SI and the drive's units, the error, the time and how it stopped.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["report_lines"]


def _si(value: float | None, unit: str, factor: float) -> str:
    """``value`` [unit] and its drive units (``factor`` per unit)."""
    if value is None or not math.isfinite(value):
        return "-"
    units = f" ({value * factor:.0f} drive units)" if math.isfinite(factor) and factor else ""
    return f"{value:.6g} {unit}{units}"


def report_lines(action: str, r: dict[str, Any], position_factor: float, velocity_factor: float) -> list[str]:
    """A move's report for a person: asked, reached, error, time, the stop in words (``action``:
    jog, move, home); the factors: the drive's units per rad and per rad/s.

    Parameters
    ----------
    action : str
        jog, move or home.
    r : dict[str, Any]
        The report.
    position_factor : float
        Device units per rad.
    velocity_factor : float
        Per rad/s.

    Returns
    -------
    list[str]
        The lines.
    """
    rows: list[tuple[str, str]] = []
    if action == "jog":
        rows.append(("asked", f"{r['asked_rad_s']:g} rad/s" + _also(r)))
        rows.append(("reached", _si(r.get("reached_rad_s"), "rad/s", velocity_factor)))
    elif action == "move":
        how = "relative" if r.get("relative") else "absolute"
        rows.append(("target", f"{r['target_rad']:.6g} rad ({how})" + _also(r)))
        rows.append(("reached", _si(r.get("reached_rad"), "rad", position_factor)))
        rows.append(
            ("error", f"{r['error_rad']:.4g} rad ({r['error_units']} drive units): {r['error_said']}")
        )
        rows.append(
            ("time", f"{r['time_s']:.3g} s" + (f", held {r['held_s']:.3g} s" if r.get("held_s") else ""))
        )
    else:
        method = r.get("method")
        rows.append(("homing", f"method {method}" if method is not None else "the drive's own method"))
        rows.append(("time", f"{r['time_s']:.3g} s"))
    rows.append(("result", str(r["result"])))
    if "position_rad" in r:
        rows.append(("position", _si(r["position_rad"], "rad", position_factor)))
    rows.append(("velocity", _si(r["velocity_rad_s"], "rad/s", velocity_factor)))
    rows.append(("stop", r["stop"]))
    return [f"{key:15s} {text}" for key, text in rows]


def _also(r: dict[str, Any]) -> str:
    """The speed and acceleration a move asked, as ", at ... rad/s, ... rad/s^2" (or nothing)."""
    parts = [f"at {r['speed_rad_s']:g} rad/s"] if "speed_rad_s" in r else []
    parts += [f"{r['accel_rad_s2']:g} rad/s^2"] if "accel_rad_s2" in r else []
    return (", " + ", ".join(parts)) if parts else ""
