"""Open-loop laws: ``speed-reference`` and ``position-reference`` (the reference is the command, to
the drive's own speed or position loop) and ``replay`` (a recorded input)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drivers.base import Feedback
from drivers.errors import SafetyStop
from drivers.schema import Refused, key
from rig.laws.base import Law, LawParams, LawStep, Reference

__all__ = [
    "Excitation",
    "PositionReferenceLaw",
    "PositionReferenceParams",
    "ReplayLaw",
    "ReplayParams",
    "SpeedReferenceLaw",
    "SpeedReferenceParams",
]


@dataclass(frozen=True)
class SpeedReferenceParams(LawParams):
    """No parameters: the speed reference goes to the drive's own speed loop (an inverter's ramp)."""


class SpeedReferenceLaw(Law):
    """Command = reference [rad/s]; measurement = the read axis's speed."""

    Params = SpeedReferenceParams
    modes = (frozenset({"speed", "csv", "pv"}),)

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        w_r, _ = self.reference(t)
        return LawStep((w_r,), w_r, feedback[0].velocity)


@dataclass(frozen=True)
class PositionReferenceParams(LawParams):
    """No parameters: the position reference is streamed to the drive's own loops (CSP)."""


class PositionReferenceLaw(Law):
    """Command = reference [rad], every cycle, to a drive in CSP or in ip (its position and speed
    loops inside; in ip one record a SYNC, interpolated by the drive); measurement = the read
    axis's position."""

    Params = PositionReferenceParams
    error_unit = "rad"
    modes = (frozenset({"csp", "ip"}),)
    position_reference = True

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        theta_r, _ = self.reference(t)
        return LawStep((theta_r,), theta_r, feedback[0].position)


@dataclass(frozen=True)
class ReplayParams(LawParams):
    """An input sequence, one value per cycle (``rig identify``'s excitation)."""

    u: tuple[float, ...] = key((), "V", "the input, one value per cycle (or in the unit of the mode)")
    one_sign: bool = key(False, "", "stop when the speed changes sign after the first 10 % (friction)")
    cycles: int = key(
        0,
        "cycles",
        "u is one period, repeated over this many cycles (a chirp or multisine; keeps config.json small)",
        ge=0,
        also={0: "u is the whole run, its last value held"},
    )
    dither: float = key(
        0.0,
        "unit of u",
        "standard deviation of a white Gaussian dither added to every cycle (seeded by seed): it keeps "
        "the encoder's quantisation error from repeating with a periodic u",
        ge=0.0,
    )
    seed: int = key(0, "", "the dither's seed", ge=0)

    def rules(self, period: float) -> None:
        """An input sequence is given.

        Parameters
        ----------
        period : float
            [s] the run's.

        Raises
        ------
        Refused
            If no input sequence is given.
        """
        if not self.u:
            raise Refused("u", self.u, "replay needs an input sequence u")


class Excitation:
    """The sequence a replay sends: ``u`` (one value per cycle, its last held), or ``u`` as one
    period repeated over ``cycles``; plus a seeded white dither of standard deviation ``dither``
    over the run. ``next()`` gives the next value. Its values were checked when the configuration
    was loaded (``ReplayParams``, ``ExcitedSpeedParams``: u not empty, cycles and dither >= 0).

    Parameters
    ----------
    u : tuple[float, ...]
        The sequence [unit of u].
    cycles : int
        Cycles it runs (0: ``u`` once, its last held).
    dither : float
        Its standard deviation [unit of u].
    seed : int
        Of the dither.
    """

    def __init__(self, u: tuple[float, ...], cycles: int, dither: float, seed: int) -> None:
        self._u, self._periodic, self._k = u, cycles > 0, 0
        self.total = cycles or len(u)  #: the run's cycles
        self._dither = (
            np.random.default_rng(seed).normal(0.0, dither, self.total).tolist() if dither else None
        )

    @property
    def count(self) -> int:
        """Values given so far."""
        return self._k

    def next(self) -> float:
        """The next value.

        Returns
        -------
        float
            [unit of u].
        """
        n = len(self._u)
        k = self._k % n if self._periodic else min(self._k, n - 1)
        self._k += 1
        u = self._u[k]
        if self._dither is not None and self._k <= len(self._dither):
            u += self._dither[self._k - 1]
        return u


class ReplayLaw(Law):
    """Replays ``u``; reference = command, measurement = the read axis's position.

    Parameters
    ----------
    params : ReplayParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The reference.
    """

    Params = ReplayParams
    modes = (frozenset({"voltage", "cst"}),)
    error_unit = ""  #: the command against a position: no error in one unit

    def __init__(self, params: ReplayParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        self._excitation = Excitation(params.u, params.cycles, params.dither, params.seed)
        self._settled = self._excitation.total // 10

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        fb = feedback[0]
        if self.params.one_sign and fb.velocity < 0.0 and self._excitation.count > self._settled:
            raise SafetyStop(f"speed {fb.velocity:.3g} rad/s changed sign: raise u0 above the friction")
        u = self._excitation.next()
        return LawStep((u,), u, fb.position)
