"""Separately excited / permanent-magnet DC motor, eqs. (3.4)-(3.7) of the drives paper.

Two models, both stepped exactly by ZOH over ``dt`` (inputs held):

- ``DCMotor``: the full model (3.4) with armature current and position (3.6),
  state [theta, omega, i_r], inputs [u_r, T_L];
- ``ReducedDCMotor``: the reduced model (3.5) with position, i.e. (3.7),
  state [theta, omega], inputs [u_r, T_L]; dw/dt = -a_m w + b_m u - T_L/J with a_m the
  whole damping, (3.5)'s a_m + B/J (an identified a_m holds B; ``DCMotorParams.from_am_bm``).

A matched disturbance f (in volts, acting as u + f, eq. (6.1)) is the same as a
load T_L = -J b_m f; ``ReducedDCMotor.step`` takes it directly as ``f``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from plant_emulator.zoh import LinearZOH

__all__ = ["DCMotor", "DCMotorParams", "ReducedDCMotor"]


@dataclass(frozen=True, slots=True)
class DCMotorParams:
    """Parameters of (3.4); SI units.

    Raises
    ------
    ValueError
        If a parameter is not > 0 (B: >= 0).
    """

    r_r: float  #: armature resistance R_r [Ohm]
    l_r: float  #: armature inductance L_r [H]
    k_e: float  #: back-EMF constant k_e [V s/rad]
    k_t: float  #: torque constant k_t [N m/A]
    j: float  #: total inertia J [kg m^2]
    b: float = 0.0  #: viscous friction B [N m s/rad]

    def __post_init__(self) -> None:
        for name in ("r_r", "l_r", "j"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"DC motor parameter {name} must be > 0, got {value!r}")
        for name in ("k_e", "k_t", "b"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"DC motor parameter {name} must be >= 0, got {value!r}")
        if self.k_t == 0.0:
            raise ValueError("DC motor parameter k_t must be > 0")

    @property
    def a_m(self) -> float:
        """a_m = k_t k_e / (J R_r) of (3.5) [1/s]: the electrical part of the damping, which with
        the viscous B/J makes the a_m a model identified on the motor has."""
        return self.k_t * self.k_e / (self.j * self.r_r)

    @property
    def damping(self) -> float:
        """a_m + B/J [1/s]: the whole coefficient of w in (3.5), the a_m identification measures."""
        return self.a_m + self.b / self.j

    @property
    def b_m(self) -> float:
        """b_m = k_t / (J R_r) of (3.5) [rad/(V s^2)]."""
        return self.k_t / (self.j * self.r_r)

    @classmethod
    def from_am_bm(
        cls, *, a_m: float, b_m: float, r_r: float = 1.0, tau_e: float = 1e-4, b: float = 0.0
    ) -> DCMotorParams:
        """A motor whose speed model has the given a_m [1/s] and b_m [rad/(V s^2)], and whose
        viscous friction B [N m s/rad] is part of that a_m.

        a_m here is the damping a model identified on the motor has: the whole coefficient of w
        in (3.5), a_m + B/J in the paper's letters (what (7.28) calls a_m, "identified as
        a_m = 16"). B is inside it, not added to it: with k_e = k_t = k (SI) and J = k/(R_r b_m),
        a_m = k b_m + B/J = k b_m + B R_r b_m/k, so k is the larger root of
        b_m k^2 - a_m k + B R_r b_m = 0 (the motor whose damping is mostly electrical; B = 0:
        k = a_m/b_m). L_r = tau_e R_r with the electrical time constant tau_e [s].

        Parameters
        ----------
        a_m : float
            [1/s] of (3.5).
        b_m : float
            [rad/(V s^2)] of (3.5).
        r_r : float, optional
            [Ohm] the armature resistance.
        tau_e : float, optional
            [s] the electrical time constant L_r/R_r.
        b : float, optional
            [N m s/rad] the viscous friction, part of ``a_m``.

        Returns
        -------
        DCMotorParams
            The motor.

        Raises
        ------
        ValueError
            If ``a_m`` or ``b_m`` is not > 0, ``b`` < 0, or ``b`` leaves no room in ``a_m``.
        """
        if not (a_m > 0.0 and b_m > 0.0):
            raise ValueError(f"a_m and b_m must be > 0, got a_m={a_m!r}, b_m={b_m!r}")
        if not (math.isfinite(b) and b >= 0.0):
            raise ValueError(f"DC motor parameter b (viscous friction) must be >= 0, got {b!r}")
        discriminant = a_m * a_m - 4.0 * b * r_r * b_m * b_m
        if discriminant < 0.0:
            raise ValueError(
                f"viscous friction B = {b!r} N m s/rad does not fit a_m = {a_m!r} 1/s (B is part of a_m): "
                f"at most a_m^2/(4 R_r b_m^2) = {a_m * a_m / (4.0 * r_r * b_m * b_m):.4g} N m s/rad"
            )
        k = (a_m + math.sqrt(discriminant)) / (2.0 * b_m)
        return cls(r_r=r_r, l_r=tau_e * r_r, k_e=k, k_t=k, j=k / (r_r * b_m), b=b)


class _ShaftModel:
    """A linear motor model stepped by ZOH whose first two states are [theta, omega]."""

    __slots__ = ("_zoh",)
    _zoh: LinearZOH

    @property
    def theta(self) -> float:
        """Shaft angle [rad]."""
        return self._zoh.x[0]

    @property
    def omega(self) -> float:
        """Shaft speed [rad/s]."""
        return self._zoh.x[1]


class DCMotor(_ShaftModel):
    """Full DC motor (3.4) with position (3.6): state [theta, omega, i_r].

    Parameters
    ----------
    params : DCMotorParams
        The motor's parameters.
    dt : float
        [s] the step.
    """

    __slots__ = ("params",)

    def __init__(self, params: DCMotorParams, *, dt: float) -> None:
        p = params
        A = [
            [0.0, 1.0, 0.0],
            [0.0, -p.b / p.j, p.k_t / p.j],
            [0.0, -p.k_e / p.l_r, -p.r_r / p.l_r],
        ]
        B = [[0.0, 0.0], [0.0, -1.0 / p.j], [1.0 / p.l_r, 0.0]]
        self.params = p
        self._zoh = LinearZOH(A, B, dt)

    @property
    def current(self) -> float:
        """Armature current i_r [A]."""
        return self._zoh.x[2]

    def set_state(self, theta: float = 0.0, omega: float = 0.0, current: float = 0.0) -> None:
        """Set the state [rad, rad/s, A].

        Parameters
        ----------
        theta : float, optional
            [rad].
        omega : float, optional
            [rad/s].
        current : float, optional
            [A].
        """
        self._zoh.x[:] = [theta, omega, current]

    def step(self, u: float, t_load: float = 0.0) -> None:
        """Advance dt with armature voltage u [V] and load torque t_load [N m] held.

        Parameters
        ----------
        u : float
            [V] the armature voltage.
        t_load : float, optional
            [N m] the load torque.
        """
        self._zoh.step((u, t_load))


class ReducedDCMotor(_ShaftModel):
    """Reduced DC motor (3.5) with position, i.e. (3.7): state [theta, omega].

    Parameters
    ----------
    a_m : float
        [1/s] of (3.5).
    b_m : float
        [rad/(V s^2)] of (3.5).
    dt : float
        [s] the step.
    j : float, optional
        [kg m^2] the inertia (scales the load torque).

    Raises
    ------
    ValueError
        If ``a_m`` or ``b_m`` is not finite, ``b_m`` is 0, or ``j`` <= 0.
    """

    __slots__ = ("a_m", "b_m", "j")

    def __init__(self, *, a_m: float, b_m: float, dt: float, j: float = 1.0) -> None:
        if not (math.isfinite(a_m) and math.isfinite(b_m) and b_m != 0.0 and j > 0.0):
            raise ValueError(f"need finite a_m, b_m != 0, j > 0; got {a_m!r}, {b_m!r}, {j!r}")
        self.a_m, self.b_m, self.j = a_m, b_m, j
        A = [[0.0, 1.0], [0.0, -a_m]]
        B = [[0.0, 0.0, 0.0], [b_m, -1.0 / j, b_m]]
        self._zoh = LinearZOH(A, B, dt)

    def set_state(self, theta: float = 0.0, omega: float = 0.0) -> None:
        """Set the state [rad, rad/s].

        Parameters
        ----------
        theta : float, optional
            [rad].
        omega : float, optional
            [rad/s].
        """
        self._zoh.x[:] = [theta, omega]

    def step(self, u: float, t_load: float = 0.0, f: float = 0.0) -> None:
        """Advance dt with u [V], load torque [N m] and matched disturbance f [V] held.

        Parameters
        ----------
        u : float
            [V].
        t_load : float, optional
            [N m] the load torque.
        f : float, optional
            [V] the matched disturbance.
        """
        self._zoh.step((u, t_load, f))
