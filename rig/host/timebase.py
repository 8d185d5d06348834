"""The run's clock: its period, read once from the configuration, and how its time passes.

``Timebase.of(cfg)`` reads ``RigConfig.period`` (``[run] period``, else the emulated preset's)
and ``[run] time`` once; the session hands the one ``Timebase`` to the transport, the pacing and
the loop, which take the period from it (docs/time.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rig.config import RigConfig

__all__ = ["Timebase"]


@dataclass(frozen=True, slots=True)
class Timebase:
    """The run's clock (module docstring).

    Parameters
    ----------
    period : float
        [s] of a cycle.
    lockstep : bool
        Time passes by the cycles (the SYNCs), not by the wall clock (``[run] time = "lockstep"``;
        else real time).
    """

    period: float
    lockstep: bool = True

    @classmethod
    def of(cls, cfg: RigConfig) -> Timebase:
        """The timebase of ``cfg`` (checked when it was loaded).

        Parameters
        ----------
        cfg : RigConfig
            The loaded configuration.

        Returns
        -------
        Timebase
            Its period and time.
        """
        return cls(cfg.period, cfg.run.time == "lockstep")

    @property
    def realtime(self) -> bool:
        """Time is the wall clock's: deadlines are slept to."""
        return not self.lockstep

    def cycles(self, duration: float) -> int:
        """The cycles of ``duration``.

        Parameters
        ----------
        duration : float
            [s] finite, > 0.

        Returns
        -------
        int
            The number of cycles, rounded.

        Raises
        ------
        ValueError
            If ``duration`` is not finite and > 0.
        """
        if not (math.isfinite(duration) and duration > 0.0):
            raise ValueError(f"duration = {duration!r}: must be a finite time > 0 s")
        return round(duration / self.period)
