"""``excited-speed``: ``rig identify``'s closed-loop experiment, a weak PI speed loop holding a
constant speed, with the excitation r added to its command (the torque in CST).

Where u is a torque and the plant is nearly an integrator (dw/dt = -(B/J) w + u/J, B small),
an open-loop excitation on a bias runs away, and one without a bias crosses zero speed, where
Coulomb friction is not linear. The loop holds the speed at ``speed`` (one sign: Coulomb
friction is a constant torque there, which its integral takes), and is weak (its crossover
well below the excitation's band), so that the command is mostly the excitation; the plant is
then estimated from r as the instrument (``rig.identify.frequency``, the indirect method). The
excitation is recorded as the internal column ``excitation``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from controllers.pi import PI, PIParams
from drivers.base import Feedback
from drivers.errors import SafetyStop
from drivers.schema import Refused, key
from rig.laws.base import Law, LawParams, LawStep, Reference
from rig.laws.open_loop import Excitation

__all__ = ["ExcitedSpeedLaw", "ExcitedSpeedParams"]


@dataclass(frozen=True)
class ExcitedSpeedParams(LawParams):
    """The excitation (as ``ReplayParams``) and the loop: u_k = PI(speed - w_k) + r_k (T is the
    run's period)."""

    u: tuple[float, ...] = key((), "unit of the command", "r, one period (cycles > 0) or the run")
    cycles: int = key(
        0, "cycles", "u is one period, repeated over this many cycles", ge=0, also={0: "u is the whole run"}
    )
    dither: float = key(0.0, "unit of u", "standard deviation of a seeded white dither added to r", ge=0.0)
    seed: int = key(0, "", "the dither's seed", ge=0)
    speed: float = key(0.0, "rad/s", "the loop's constant reference", nonzero=True)
    kp: float = key(0.0, "unit of u per rad/s", "the loop's proportional gain", gt=0.0)
    ki: float = key(0.0, "unit of u per rad", "the loop's integral gain", ge=0.0)

    def rules(self, period: float) -> None:
        """An excitation is given.

        Parameters
        ----------
        period : float
            [s] the run's.

        Raises
        ------
        Refused
            If no excitation is given.
        """
        if not self.u:
            raise Refused("u", self.u, "the closed-loop experiment needs an excitation u")


class ExcitedSpeedLaw(Law):
    """u = k_p e + k_i T sum(e) + r, e = speed - w (the read axis's reported speed); reference =
    command, measurement = the read axis's position (as ``replay``); a speed of the other sign
    than ``speed`` after the first tenth of the run is a safe stop.

    Parameters
    ----------
    params : ExcitedSpeedParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The reference.
    """

    Params = ExcitedSpeedParams
    modes = (frozenset({"voltage", "cst"}),)
    error_unit = ""  #: the command against a position, as replay's
    internals = ("excitation", "integral")

    def __init__(self, params: ExcitedSpeedParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        self._excitation = Excitation(params.u, params.cycles, params.dither, params.seed)
        self._settled = self._excitation.total // 10
        self.pi = PI(PIParams(kp=params.kp, ki=params.ki, dt=period))

    def sensitivity(self) -> tuple[float, float]:
        """(0, k_p + k_i T): the command per rad/s of speed in one period.

        Returns
        -------
        tuple[float, float]
            (0, k_p + k_i T).
        """
        return (0.0, self.params.kp + self.params.ki * self.period)

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        fb, w_r = feedback[0], self.params.speed
        if fb.velocity * w_r < 0.0 and self._excitation.count > self._settled:
            raise SafetyStop(
                f"speed {fb.velocity:.3g} rad/s changed sign: raise the loop's speed ({w_r:g} rad/s, "
                "--speed) or lower --amplitude"
            )
        r = self._excitation.next()
        u = self.pi.step(w_r - fb.velocity) + r
        return LawStep((u,), u, fb.position, (r, self.pi.integral))
