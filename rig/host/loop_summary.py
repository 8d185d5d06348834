"""The summary of a host loop's run (``rig.host.loop.HostLoop.summary``): the tracking figures, the
counts, the stop, the timing and what real time was granted; summary.json's keys
(docs/files.md)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

from rig.host.columns import MODE_UNITS
from rig.report.summary import failed_figures

if TYPE_CHECKING:
    from drivers.base import AxisDriver
    from rig.host.control import Wiring
    from rig.host.loop_stats import RunMetrics, StageTimes
    from rig.host.pacing import Pacing
    from rig.host.recorder import Recorder
    from rig.laws.base import Law

__all__ = ["MISSED_SHARE", "RunState", "loop_summary", "missed_period"]

MISSED_SHARE = 0.01  #: a real-time run whose skipped and late cycles exceed this share missed its period


class RunState(Protocol):
    """What a summary reads of a run: ``rig.host.loop.HostLoop``'s (its attributes say what each
    holds), named here so this module need not import the loop that imports it."""

    axes: list[AxisDriver]
    law: Law
    wiring: Wiring
    recorder: Recorder
    pacing: Pacing
    metrics: RunMetrics
    times: StageTimes
    overruns: int
    late: int
    elapsed: float
    safe_stop_reason: str | None
    stop_confirmed: bool | None
    still_turning: dict[str, float | None]
    granted: dict[str, Any] | None
    collections: int
    stolen: float | None

    @property
    def done(self) -> int:
        """Cycles run."""
        ...

    @property
    def held(self) -> int:
        """Cycles in which a read axis had no new sample."""
        ...


def loop_summary(loop: RunState) -> dict[str, Any]:
    """``loop``'s summary as it stands: summary.json's keys (docs/files.md).

    A safe stop's too: ``status`` "stopped", every performance figure NaN, and what they were when
    it stopped under ``cut_short``.

    Parameters
    ----------
    loop : RunState
        The loop (``rig.host.loop.HostLoop``), run or stopped.

    Returns
    -------
    dict[str, Any]
        The summary.
    """
    n = loop.done
    m = loop.metrics
    units = {a.name: MODE_UNITS.get(a.mode, "") for a in loop.axes if a.mode is not None}
    commands = loop.wiring.commands
    figures = {
        "rms_error": m.rms_error(n),
        "max_error": m.max_error if n else math.nan,
        **m.chatter.figures(),
    }
    status = "completed" if loop.safe_stop_reason is None else "stopped"
    return {
        "status": status,
        "cycles": n,
        **(figures if status == "completed" else failed_figures(figures, "the run stopped")),
        "error_unit": loop.law.error_unit,
        # the unit of the law's first command (chattering's) and of each axis's command
        "command_unit": units.get(loop.axes[commands[0]].name, "") if commands else "",
        "command_units": units,
        "overruns": loop.overruns,
        "held_cycles": loop.held,
        "late_cycles": loop.late,
        "elapsed_s": loop.elapsed,
        "safe_stop_reason": loop.safe_stop_reason,
        "stop_confirmed": loop.stop_confirmed,
        "still_turning": loop.still_turning,
        "run_dir": str(loop.recorder.dir),
        "timing": loop.times.stats(),
        "realtime": None
        if loop.granted is None
        else {
            **loop.granted,
            "gc_collections": loop.collections,
            "bus_read_by": loop.pacing.bus_read_by,
            "cpu_stolen_s": loop.stolen,
        },
        "axes": m.axis_peaks(),
    }


def missed_period(summary: dict[str, Any], period: float) -> str | None:
    """Whether a real-time run did not keep its period: skipped and late cycles over ``MISSED_SHARE``.

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary (`loop_summary`).
    period : float
        The loop's period [s].

    Returns
    -------
    str | None
        One line naming the figures and ``rig doctor``; None where the period was kept or the run
        was lock-step.
    """
    if summary.get("realtime") is None:
        return None
    skipped, late = int(summary.get("overruns") or 0), int(summary.get("late_cycles") or 0)
    scheduled = int(summary.get("cycles") or 0) + skipped
    if not scheduled or (skipped + late) <= MISSED_SHARE * scheduled:
        return None
    return (
        f"this run did not keep its period of {period * 1e6:g} us: {skipped} of {scheduled} cycles skipped "
        f"({100.0 * skipped / scheduled:.2g} %) and {late} late ({100.0 * late / scheduled:.2g} %), "
        f"{100.0 * (skipped + late) / scheduled:.3g} % together, over {100.0 * MISSED_SHARE:g} %; "
        "its samples are not those of lock-step. `rig doctor --period "
        f"{period:g}` says what this PC gives and what to change"
    )
