"""A run's chattering figures, kept as the cycles go (docs/chattering.md): the resolution of the
feedback the law read, the count of the command's alternations beyond one count's effect, the
RMS increment and the sign-law share. Nothing grows with the run's length.

Until the steady state (the run's second half) the quantum of the first read axis's position
and speed steps between samples is measured (the largest of which every step is a whole
multiple, ``rig.report.metrics.feedback_resolution``); at its start the threshold is fixed
from it (``rig.report.metrics.count_threshold``: the law's ``sensitivity`` times the
resolution, each the measured step where one was seen, else the quantum the device or the
encoder declares, ``AxisDriver.quanta``) and the count runs over the steady state.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import Any

from rig.report.metrics import beyond, common_quantum, count_threshold, measured_quantum, not_measurable

__all__ = ["ChatterCounter", "RunChatter"]


class ChatterCounter:
    """``rig.report.metrics.chattering_count`` and ``chattering_amplitude`` computed as the samples arrive.

    Parameters
    ----------
    threshold : float
        ``rig.report.metrics.count_threshold`` for the law and the read axis [unit of u], widened by
        ``rig.report.metrics.beyond`` (set until ``start``).
    start : int
        The first sample that counts (the steady state's).
    """

    def __init__(self, threshold: float, *, start: int = 0) -> None:
        self.threshold = beyond(threshold)
        self.start = start  #: the first sample of the steady state
        self.count = 0
        self._n = 0
        self._sq = 0.0
        self._increments = 0
        self._last: float | None = None
        self._sign = 0.0

    @property
    def amplitude(self) -> float:
        """RMS of the command increment over the steady state [unit of u]; NaN before two samples."""
        return math.sqrt(self._sq / self._increments) if self._increments else math.nan

    def add(self, u: float) -> None:
        """One sample of the command.

        Parameters
        ----------
        u : float
            The command [its unit].
        """
        n = self._n
        self._n = n + 1
        if n < self.start:
            return
        if self._last is not None:
            du = u - self._last
            self._sq += du * du
            self._increments += 1
            if abs(du) > self.threshold:
                sign = 1.0 if du > 0 else -1.0
                if self._sign and sign != self._sign:
                    self.count += 1
                self._sign = sign
        self._last = u


class _Steps:
    """The quantum of one measured quantity's steps |x_k - x_k-1| as they come
    (``rig.report.metrics.feedback_resolution``; ``step`` 0: none seen, or no quantum)."""

    __slots__ = ("continuous", "last", "step")

    def __init__(self) -> None:
        self.last = math.nan
        self.step = 0.0
        self.continuous = False  #: the steps have no common quantum

    def add(self, x: float) -> None:
        d = abs(x - self.last)
        self.last = x
        if not d > 0.0 or self.continuous or d == self.step:  # NaN compares false: skipped
            return
        self.step = common_quantum(self.step, d) if self.step else d
        self.continuous = not self.step


class RunChatter:
    """The chattering figures of a run (module docstring): ``add`` every cycle, ``figures`` at the end.

    Parameters
    ----------
    sensitivity : tuple[float, float]
        The law's (|du/dtheta|, |du/domega|).
    declared : tuple[float, float]
        The read axis's quanta: one position count [rad], one speed unit [rad/s].
    read : int | None
        The read axis's index in a cycle's samples (None: the law reads none, the threshold is
        rounding's).
    measures : Collection[str]
        The read axis's measured fields.
    sign_column : int | None
        The index of the law's ``SIGN_LAW`` internal (None: not a sliding-mode law).
    steady_from : int
        The cycle the steady state, and the count, begins.
    command_range : float
        The largest increment the first command can make (twice its limit) [command unit].
    """

    def __init__(
        self,
        sensitivity: tuple[float, float],
        declared: tuple[float, float],
        *,
        read: int | None,
        measures: Collection[str],
        sign_column: int | None,
        steady_from: int,
        command_range: float = math.inf,
    ) -> None:
        self.sensitivity = sensitivity
        self.declared = declared
        self.read = read
        self.sign_column = sign_column
        self.steady_from = steady_from
        self.command_range = command_range
        self.counter = ChatterCounter(0.0, start=steady_from)
        self._position = _Steps() if read is not None and "position" in measures else None
        self._velocity = _Steps() if read is not None and "velocity" in measures else None
        self.resolution = (0.0, 0.0)  #: the quanta the threshold was made of [rad, rad/s]
        self.measured = (False, False)  #: each from the samples (else declared)
        self.threshold = 0.0  #: [command unit]
        self._fixed = False
        self._n = 0
        self._sign_cycles = 0
        self._steady_cycles = 0

    def add(self, u: float, samples: Sequence[Any], internals: Sequence[float]) -> None:
        """One cycle.

        Parameters
        ----------
        u : float
            Its first command [command unit].
        samples : Sequence[Any]
            Every axis's feedback.
        internals : Sequence[float]
            The law's internals.
        """
        n = self._n
        self._n = n + 1
        if n < self.steady_from:
            if self.read is not None:
                fb = samples[self.read]
                if self._position is not None:
                    self._position.add(fb.position)
                if self._velocity is not None:
                    self._velocity.add(fb.velocity)
        else:
            if not self._fixed:
                self.fix()
            self._steady_cycles += 1
            if self.sign_column is not None and internals[self.sign_column]:
                self._sign_cycles += 1
        self.counter.add(u)

    def fix(self) -> None:
        """Fix the threshold from the resolution seen so far (the steady state begins)."""
        steps = [s.step if s is not None else 0.0 for s in (self._position, self._velocity)]
        q = tuple(measured_quantum(d, m) for d, m in zip(self.declared, steps))
        self.resolution = (q[0], q[1])
        self.measured = (steps[0] > 0.0, steps[1] > 0.0)
        self.threshold = count_threshold(self.sensitivity, position_quantum=q[0], velocity_quantum=q[1])
        self.counter.threshold = beyond(self.threshold)
        self._fixed = True

    def figures(self) -> dict[str, Any]:
        """The summary's chattering keys (docs/files.md).

        Returns
        -------
        dict[str, Any]
            ``chattering_count`` (NaN, with ``chattering_note`` saying why, where it cannot be
            measured), ``chattering_amplitude``, ``chattering_threshold``, ``feedback_resolution`` and
            ``sign_law_share`` (NaN for a law that is not a sliding-mode law, or before the steady state).
        """
        if not self._fixed:
            self.fix()
        note = not_measurable(self.threshold, self.command_range)
        if not self._steady_cycles:
            note = "not measured: the run ended before its second half (its steady state) began"
        sources = {"samples" if m else "declared" for m in self.measured}
        share = self._sign_cycles / self._steady_cycles if self._steady_cycles else math.nan
        return {
            "chattering_count": math.nan if note else self.counter.count,
            "chattering_note": note,
            "chattering_amplitude": self.counter.amplitude,
            "chattering_threshold": self.threshold,
            "feedback_resolution": {
                "position": self.resolution[0],
                "velocity": self.resolution[1],
                "source": " and ".join(sorted(sources)),
            },
            "sign_law_share": share if self.sign_column is not None else math.nan,
        }
