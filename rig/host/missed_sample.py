"""The law's step only on new samples: what a host loop's cycle does when a read axis has none.

A cycle in which a read axis has no new sample (a TPDO missed or late: its stamp unchanged, or
none) does not step the law on stale feedback: ``[run] missed_sample = "hold"`` keeps the last
commands (sent again, the same values: the drives hold them, and their deadlines see a host
alive), ``"zero"`` sends the neutral ones (``AxisDriver.neutral_command``) and tells the law
(``Law.held``: an observer then predicts with what the drives hold).
"""

from __future__ import annotations

from collections.abc import Sequence

from drivers.base import AxisDriver, Feedback
from rig.laws.base import Law, LawStep

__all__ = ["FreshSteps"]


class FreshSteps:
    """``step`` the law on each cycle's samples where they are new (module docstring).

    Parameters
    ----------
    law : Law
        The run's law.
    axes : Sequence[AxisDriver]
        The loop's axes.
    commands : Sequence[int]
        The indices of the axes the law commands.
    missed : str
        ``[run] missed_sample``: "hold" | "zero".
    """

    def __init__(self, law: Law, axes: Sequence[AxisDriver], commands: Sequence[int], missed: str) -> None:
        self.law, self.axes, self.commands, self.missed = law, axes, commands, missed
        self.held = 0  #: cycles in which a read axis had no new sample
        self._last: LawStep | None = None
        self._stamps: list[float | None] = []

    def step(self, t: float, reads: list[Feedback]) -> tuple[LawStep, bool]:
        """The law's step on ``reads``, and whether to send its commands.

        Parameters
        ----------
        t : float
            [s] the cycle's time.
        reads : list[Feedback]
            The samples of the axes the law reads.

        Returns
        -------
        tuple[LawStep, bool]
            The step (the law's, the last one held, or the neutral commands), and False where the last
            commands are held and need not be sent.
        """
        stamps = [fb.stamp for fb in reads]
        last = self._last
        fresh = True
        if last is not None:
            for s, p in zip(stamps, self._stamps):
                if s is None or s == p:
                    fresh = False
                    break
        self._stamps = stamps
        if fresh or last is None:
            self._last = self.law.step(t, reads)
            return self._last, True
        self.held += 1
        if self.missed == "hold":
            return last, False
        neutral = [self.axes[i].neutral_command() for i in self.commands]
        commands = tuple(c if n is None else n for c, n in zip(last.commands, neutral))
        self.law.held(commands)
        return LawStep(commands, last.reference, last.measurement, last.internals), True
