"""Host-side fault injection: a law that turns bad at a given time (NaN, an exception, Ctrl-C).

``with_injected_faults(law, faults)`` returns ``law`` itself when ``[faults]`` names
no host fault, else a ``FaultyLaw`` around it, built with it: the run's law is
never patched afterwards.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from drivers.base import Feedback
from rig.config import FaultsConfig
from rig.laws.base import Law, LawStep

__all__ = ["FaultyLaw", "InjectedFault", "with_injected_faults"]


class InjectedFault(RuntimeError):
    """The exception ``law_error_at`` raises from the law."""


class FaultyLaw(Law):
    """``inner`` until the first fault time of ``faults``, then that fault.

    Parameters
    ----------
    inner : Law
        The run's law.
    faults : FaultsConfig
        ``[faults]``: the times [s] of the law's NaN, exception and Ctrl-C.
    """

    def __init__(self, inner: Law, faults: FaultsConfig) -> None:
        super().__init__(inner.params, period=inner.period, reference=inner.reference)
        self.inner = inner
        self.faults = faults
        self.modes = inner.modes  # type: ignore[misc]
        self.reads = inner.reads  # type: ignore[misc]
        self.internals = inner.internals  # type: ignore[misc]
        self.error_unit = inner.error_unit  # type: ignore[misc]
        self._half = inner.period / 2.0

    def begin(self, feedback: Sequence[Feedback]) -> None:
        self.inner.begin(feedback)
        self.offset = self.inner.offset

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        """``inner``'s step, or the fault due in the cycle nearest to its time.

        Parameters
        ----------
        t : float
            [s] the cycle's time.
        feedback : Sequence[Feedback]
            Each axis's sample.

        Returns
        -------
        LawStep
            ``inner``'s, its commands NaN once ``law_nan_at`` is due.

        Raises
        ------
        KeyboardInterrupt
            Once ``interrupt_at`` is due.
        InjectedFault
            Once ``law_error_at`` is due.
        """
        f, t = self.faults, t + self._half  # a fault at time a acts in the cycle nearest to a
        if t >= f.interrupt_at:
            raise KeyboardInterrupt
        if t >= f.law_error_at:
            raise InjectedFault(f"injected at {f.law_error_at:g} s")
        out = self.inner.step(t - self._half, feedback)
        if t >= f.law_nan_at:
            return LawStep(
                tuple(math.nan for _ in out.commands), out.reference, out.measurement, out.internals
            )
        return out


def with_injected_faults(law: Law, faults: FaultsConfig) -> Law:
    """``law``, or a ``FaultyLaw`` when ``faults`` names a host fault.

    Parameters
    ----------
    law : Law
        The run's law.
    faults : FaultsConfig
        ``[faults]``.

    Returns
    -------
    Law
        The law the run uses.
    """
    if math.isinf(min(faults.law_nan_at, faults.law_error_at, faults.interrupt_at)):
        return law
    return FaultyLaw(law, faults)
