"""What is checked at cycle 0, before the first command: a position reference against where the
read axis stands and against its position window (the guard would stop the run there anyway,
but only once the motor has moved)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from drivers.base import AxisDriver, Feedback
from drivers.errors import CommunicationError, SafetyStop
from rig.host.safety import AxisGuard
from rig.laws.base import Law, Reference

__all__ = [
    "ReferenceSpan",
    "check_absolute_start",
    "check_first_samples",
    "check_reference_window",
    "reference_span",
]

#: points of the run at which a reference is looked at (and its end)
POINTS = 2000


@dataclass(frozen=True)
class ReferenceSpan:
    """The lowest and highest value of a reference over a run, and when.

    Taken before the run (the reference is a function of time) so that cycle 0 only adds the origin.

    Parameters
    ----------
    lo, hi : float
        The lowest and highest value [rad].
    t_lo, t_hi : float
        [s] when the reference takes them.
    """

    lo: float
    t_lo: float
    hi: float
    t_hi: float

    @classmethod
    def of(cls, reference: Reference, cycles: int, period: float) -> ReferenceSpan:
        """The span of ``reference`` over a run, in at most ``POINTS`` points and the end.

        Parameters
        ----------
        reference : Reference
            t [s] -> (value, rate).
        cycles : int
            The run's cycles.
        period : float
            [s] the loop's period.

        Returns
        -------
        ReferenceSpan
            Its span.
        """
        n = max(1, min(cycles, POINTS))
        end = max(cycles - 1, 0) * period
        values = [(reference(t)[0], t) for t in [end * j / n for j in range(n)] + [end]]
        lo, hi = min(values), max(values)
        return cls(lo[0], lo[1], hi[0], hi[1])


def reference_span(
    law: Law, guards: Sequence[AxisGuard], reads: Sequence[int], cycles: int, period: float
) -> ReferenceSpan | None:
    """The span of ``law``'s position reference over the run, where the read axis has a position window.

    Parameters
    ----------
    law : Law
        The run's law.
    guards : Sequence[AxisGuard]
        The axes' guards.
    reads : Sequence[int]
        The axes the law reads (the first is checked).
    cycles : int
        The run's cycles.
    period : float
        [s] the loop's period.

    Returns
    -------
    ReferenceSpan | None
        The span; None where there is nothing to check.
    """
    law = getattr(law, "inner", law)  # (a FaultyLaw's own law)
    if not (law.position_reference and reads):
        return None
    c = guards[reads[0]].limits
    if math.isinf(c.position_min) and math.isinf(c.position_max):
        return None
    return ReferenceSpan.of(law.reference, cycles, period)


def check_absolute_start(law: Law, guard: AxisGuard, sample: Feedback) -> None:
    """An absolute position reference (``origin = "zero"``) must start where the read axis stands.

    Within the step a motor at the speed limit makes in a period (the guard's), before the first
    command would drive the shaft there at full force (a CSP axis's guard refuses such a first
    position command itself).

    Parameters
    ----------
    law : Law
        The law (its reference at 0 s).
    guard : AxisGuard
        The read axis's guard.
    sample : Feedback
        Its first sample.

    Raises
    ------
    SafetyStop
        Naming both positions and what to do.
    """
    if law.origin != "zero" or guard.position_command:
        return
    start, at = law.reference(0.0)[0], sample.position
    if abs(start - at) > guard.max_step:
        raise SafetyStop(
            f"{guard.who}: the reference starts at {start:.6g} rad, {start - at:.4g} rad from the "
            f"measured position {at:.6g} rad (> {guard.max_step:.3g} rad a period at the speed limit); "
            'origin = "zero" is absolute: home the axis first, or use origin = "start"'
        )


def check_reference_window(span: ReferenceSpan, offset: float, guard: AxisGuard, sample: Feedback) -> None:
    """A position reference must stay within the read axis's ``[position_min, position_max]``.

    A move from where a run before left the shaft is refused before the first command, not
    stopped at the window mid-move.

    Parameters
    ----------
    span : ReferenceSpan
        The reference's span.
    offset : float
        [rad] the law's origin, added to it.
    guard : AxisGuard
        The read axis's guard.
    sample : Feedback
        Its first sample.

    Raises
    ------
    SafetyStop
        Naming where and when the reference leaves the window, and what to do.
    """
    c = guard.limits
    below, above = c.position_min - (span.lo + offset), (span.hi + offset) - c.position_max
    if max(below, above) <= 0.0:
        return
    x, t = (span.lo + offset, span.t_lo) if below >= above else (span.hi + offset, span.t_hi)
    raise SafetyStop(
        f"{guard.who}: the reference goes to {x:.6g} rad (at {t:.4g} s), outside "
        f"[{c.position_min:g}, {c.position_max:g}] rad (it starts where the axis stands, "
        f"{sample.position:.6g} rad); move the shaft back (rig emulate: kill -USR1) or widen "
        "[axis.limits]"
    )


def check_first_samples(
    law: Law,
    axes: Sequence[AxisDriver],
    guards: Sequence[AxisGuard],
    reads: Sequence[int],
    *,
    span: ReferenceSpan | None,
    samples: Sequence[Feedback],
) -> None:
    """Cycle 0 of the host loop: every axis has sent a sample; the law begins on its first samples.

    The law gets the first samples of the axes it ``reads`` (``Law.begin``: a position
    reference's origin), whose start and ``span`` are checked against the first read axis's limits.

    Parameters
    ----------
    law : Law
        The run's law.
    axes : Sequence[AxisDriver]
        The loop's axes.
    guards : Sequence[AxisGuard]
        Their guards.
    reads : Sequence[int]
        The axes the law reads.
    span : ReferenceSpan | None
        The reference's span (`reference_span`).
    samples : Sequence[Feedback]
        Each axis's first sample.

    Raises
    ------
    CommunicationError
        Naming the silent axes, before any command.
    SafetyStop
        From `check_absolute_start` and `check_reference_window`.
    """
    silent = [axis.where for axis in axes if not axis.has_sample()]
    if silent:
        raise CommunicationError(f"no process data from {', '.join(silent)} after the first SYNC")
    law.begin([samples[i] for i in reads])
    inner = getattr(law, "inner", law)  # (a FaultyLaw's own law)
    if inner.position_reference and reads:
        i = reads[0]
        check_absolute_start(inner, guards[i], samples[i])
        if span is not None:
            check_reference_window(span, inner.offset, guards[i], samples[i])
