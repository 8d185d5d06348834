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
from rig.laws.base import Law, LawStep, Reference
from rig.laws.open_loop import Excitation

__all__ = ["ExcitedSpeedLaw", "ExcitedSpeedParams"]


@dataclass(frozen=True)
class ExcitedSpeedParams:
    """The excitation (as ``ReplayParams``) and the loop: u_k = PI(speed - w_k) + r_k."""

    dt: float  #: [s] the loop period
    u: tuple[float, ...] = ()  #: [unit of the command] r, one period (``cycles`` > 0) or the run
    cycles: int = 0  #: > 0: ``u`` is one period repeated over this many cycles
    dither: float = 0.0  #: [unit of u] standard deviation of a seeded white dither added to r
    seed: int = 0
    speed: float = 0.0  #: [rad/s] the loop's constant reference, != 0
    kp: float = 0.0  #: [unit of u per rad/s]
    ki: float = 0.0  #: [unit of u per rad]


class ExcitedSpeedLaw(Law):
    """u = k_p e + k_i T sum(e) + r, e = speed - w (the read axis's reported speed); reference =
    command, measurement = the read axis's position (as ``replay``); a speed of the other sign
    than ``speed`` after the first tenth of the run is a safe stop."""

    Params = ExcitedSpeedParams
    modes = (frozenset({"voltage", "cst"}),)
    error_unit = ""  #: the command against a position, as replay's
    internals = ("excitation", "integral")

    def __init__(self, params: ExcitedSpeedParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        if not params.speed or params.kp <= 0.0:
            raise ValueError(
                f"speed = {params.speed!r} rad/s, kp = {params.kp!r}: expected speed != 0, kp > 0"
            )
        self._excitation = Excitation(params.u, params.cycles, params.dither, params.seed)
        self._settled = self._excitation.total // 10
        self.pi = PI(PIParams(kp=params.kp, ki=params.ki, dt=params.dt))

    def sensitivity(self) -> tuple[float, float]:
        """(0, k_p + k_i T): the command per rad/s of speed in one period."""
        return (0.0, self.params.kp + self.params.ki * self.params.dt)

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
