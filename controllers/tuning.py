"""Tuning from an identified (3.5) and the loop's stability margins on a frequency response.

Pure functions on numbers and complex arrays; no I/O.

Designs:

- ``pi_from_bandwidth``: the PI speed loop for dw/dt = -a w + b u with its zero on the plant's
  pole (k_i / k_p = a), so that the open loop is k_p b / s and crosses 0 dB at
  omega_c = k_p b (the internal-model / lambda tuning of a first-order plant: K. J. Astrom,
  T. Hagglund, "Advanced PID Control", ISA 2006, sec. 6.4).
- ``cascade_from_bandwidths``: the cascade of section VII.D (the reconstructed (6.36) of
  ``controllers.cascade``; (6.36) is missing from the paper, so the choices below are ours).
  The speed loop is the n = 1 design (6.16)-(6.19) of (A, b) = (-a, b), and its linear
  reaching k_r1 = 1 - e^(-omega_s T) puts the pole of g_k+1 = (1 - k_r1) g_k at
  e^(-omega_s T): the speed loop's bandwidth omega_s. The position loop, as Table V does with
  -500, sees the closed speed loop as omega_s / (s + omega_s): (A, b) = ([0 1; 0 -omega_s],
  [0; omega_s]) with lambda = -omega_p, and reaches at omega_s / 2 (k_r1 = 1 - e^(-omega_s T/2):
  a deadbeat outer reaching, Table V's 0.9, asks of the speed loop what a one-period delay
  does not give). Inside the boundary layer each loop is a PI on g with the integral's corner
  kappa / (k_r1 T) (kappa = T^2 k_int / (c_1 beta)); Table V's kappa (0.02, 0.64) put that
  corner above the crossover, so here it is at a fifth of the loop's bandwidth (omega_s / 5,
  omega_p / 5). Table V's beta, k_r2 and alpha are kept. On (3.5) with a one-period delay
  this gives 46 to 73 deg of phase margin for speed bandwidths 20 to 100 Hz and position
  bandwidths a fifth to a tenth of them (``tests/controllers/test_tuning.py``).

Linear loops (``*_response``): each law, inside its boundary layers and below its limits,
is linear: u = -(C_theta(z) theta + C_w(z) w), theta the measured position, w the measured
speed, z = e^(j 2 pi f T). Broken at the plant's input, the loop gain is

    L = C_theta P_theta + C_w P_w,

with P_theta, P_w the responses from the command to the position and to the speed (measured
by ``rig identify --excitation multisine``, or a model's). ``margins`` reads the gain margin
(at -180 deg), the phase margin (at |L| = 1) and the delay margin PM / omega_c from L.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controllers.cascade import TABLE_V_POSITION, TABLE_V_SPEED, CascadeLoopParams
from controllers.design import DTSMDesign, design_dtsm

__all__ = [
    "Margins",
    "cascade_from_bandwidths",
    "cascade_response",
    "margins",
    "pi_from_bandwidth",
    "pi_response",
    "servo_response",
]


def pi_from_bandwidth(*, a: float, b: float, bandwidth: float) -> tuple[float, float]:
    """The PI speed loop crossing over at a bandwidth on dw/dt = -a w + b u.

    Parameters
    ----------
    a : float
        Plant pole a [1/s].
    b : float
        Plant gain b [rad/s^2 per unit of u], > 0.
    bandwidth : float
        Crossover omega_c [rad/s], > 0.

    Returns
    -------
    tuple of float
        (k_p, k_i): k_p = omega_c / b, k_i = a k_p (0 for a <= 0).

    Raises
    ------
    ValueError
        If the bandwidth or b is not > 0, or a is not finite.
    """
    if not (bandwidth > 0.0 and math.isfinite(bandwidth)):
        raise ValueError(f"bandwidth = {bandwidth!r} rad/s: expected > 0")
    if not (b > 0.0 and math.isfinite(b)) or not math.isfinite(a):
        raise ValueError(f"a = {a!r}, b = {b!r}: expected b > 0")
    kp = bandwidth / b
    return kp, max(a, 0.0) * kp


#: the integral's corner, a fraction of the loop's bandwidth
INTEGRAL_FRACTION = 0.2


def _loop_params(
    template: CascadeLoopParams, design: DTSMDesign, *, reach: float, corner: float, u0: float
) -> CascadeLoopParams:
    """A loop from ``design`` reaching at ``reach`` [rad/s], its integral's corner at ``corner``
    [rad/s], limited to ``u0``; ``template``'s beta, k_r2 and alpha."""
    dt = design.dt
    k_r1 = -math.expm1(-reach * dt)
    kappa = k_r1 * corner * dt  # the corner kappa / (k_r1 T)
    k_int = kappa * abs(design.c_delta[0]) * template.beta / dt**2
    return CascadeLoopParams.from_design(
        design, k_r1=k_r1, k_r2=template.k_r2, k_int=k_int, u0=u0, beta=template.beta, alpha=template.alpha
    )


def cascade_from_bandwidths(
    *,
    a: float,
    b: float,
    dt: float,
    speed_bandwidth: float,
    position_bandwidth: float,
    u_max: float,
    speed_max: float,
) -> tuple[CascadeLoopParams, CascadeLoopParams]:
    """The VII.D cascade's speed and position loops for dw/dt = -a w + b u (module docstring).

    Parameters
    ----------
    a : float
        Plant pole a [1/s].
    b : float
        Plant gain b [rad/s^2 per unit of u].
    dt : float
        Sample period T [s].
    speed_bandwidth, position_bandwidth : float
        The loops' bandwidths omega_s, omega_p [rad/s], > 0.
    u_max : float
        Limit of the speed loop's output [unit of u].
    speed_max : float
        Limit of the position loop's output, the speed reference [rad/s].

    Returns
    -------
    tuple of CascadeLoopParams
        (speed loop, position loop).

    Raises
    ------
    ValueError
        If a bandwidth is not > 0.
    """
    ws, wp = speed_bandwidth, position_bandwidth
    for name, value in (("speed_bandwidth", ws), ("position_bandwidth", wp)):
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"{name} = {value!r} rad/s: expected > 0")
    speed = _loop_params(
        TABLE_V_SPEED,
        design_dtsm(A=[[-a]], b=[b], dt=dt, lam=-ws),
        reach=ws,
        corner=INTEGRAL_FRACTION * ws,
        u0=u_max,
    )
    position = _loop_params(
        TABLE_V_POSITION,
        design_dtsm(A=[[0.0, 1.0], [0.0, -ws]], b=[0.0, ws], dt=dt, lam=-wp),
        reach=ws / 2.0,
        corner=INTEGRAL_FRACTION * wp,
        u0=speed_max,
    )
    return speed, position


def _integral(z: np.ndarray) -> np.ndarray:
    """z / (z - 1): a running sum updated before it is used."""
    out: np.ndarray = z / (z - 1.0)
    return out


def pi_response(kp: float, ki: float, dt: float, f: np.ndarray) -> np.ndarray:
    """The frequency response of ``controllers.pi``'s law.

    u_k = k_p e_k + I_k, I_k = I_k-1 + k_i T e_k-1.

    Parameters
    ----------
    kp, ki : float
        The PI's gains.
    dt : float
        Sample period T [s].
    f : numpy.ndarray
        Frequencies [Hz].

    Returns
    -------
    numpy.ndarray of complex
        C_w = k_p + k_i T/(z - 1) at z = exp(j 2 pi f T).
    """
    z = np.exp(2j * math.pi * np.asarray(f) * dt)
    out: np.ndarray = kp + ki * dt / (z - 1.0)
    return out


def servo_response(design: DTSMDesign, h: float, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The frequency response of (7.30) in its linear mode (|g|/T <= sigma + q|g|, |e_2| <= rho).

    The reference is 0, so e = -[theta, w]: u = -k e - g/T - u_I, u_I = u_I,k-1 + h g.

    Parameters
    ----------
    design : DTSMDesign
        The servo's error-space design.
    h : float
        Integral gain of (7.30c) [1/s].
    f : numpy.ndarray
        Frequencies [Hz].

    Returns
    -------
    tuple of numpy.ndarray
        (C_theta, C_w): the command per rad of position and per rad/s of speed.
    """
    z = np.exp(2j * math.pi * np.asarray(f) * design.dt)
    (c1, c2), (k1, k2) = design.c_delta, design.c_delta_A_delta
    gain = 1.0 / design.dt + h * _integral(z)
    return -(k1 + gain * c1), -(k2 + gain * c2)


def _loop(p: CascadeLoopParams, z: np.ndarray) -> np.ndarray:
    """The reconstructed (6.36)'s gain from g to u inside the boundary layer: k_r1/T (linear
    reaching) + k_int T / (c_1 beta) z/(z - 1) (the integral of sat(g / (c_1 beta)))."""
    out: np.ndarray = p.k_r1 / p.dt + p.k_int * p.dt / (p.c_s[0] * p.beta) * _integral(z)
    return out


def cascade_response(
    speed: CascadeLoopParams, position: CascadeLoopParams, k_t: float, f: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The frequency response of the cascade (both loops every period, reference 0).

    The position loop is w* = -(k theta-part) + G_p g_p, g_p = -(c_1 theta + c_2 w); the speed
    loop u = k_t (-k_s w + G_s c_s (w* - w)).

    Parameters
    ----------
    speed, position : CascadeLoopParams
        The two loops.
    k_t : float
        Torque constant from the speed loop's output to the command [unit of u per A].
    f : numpy.ndarray
        Frequencies [Hz].

    Returns
    -------
    tuple of numpy.ndarray
        (C_theta, C_w): the command per rad of position and per rad/s of speed.
    """
    z = np.exp(2j * math.pi * np.asarray(f) * speed.dt)
    gp, gs = _loop(position, z), _loop(speed, z)
    (c1, c2), (k1, k2) = position.c_s, position.k_s
    w_theta = -k1 - gp * c1  # w* per rad of theta
    w_w = -k2 - gp * c2  # w* per rad/s of w
    cs, ks = speed.c_s[0], speed.k_s[0]
    c_theta = -k_t * gs * cs * w_theta
    c_w = -k_t * (-ks + gs * cs * (w_w - 1.0))
    return c_theta, c_w


#: a margin this close to 0 (dB, deg) is at the stability boundary within what a frequency
#: response on a grid, or a measured one, resolves: the loop is marginal
GM_BOUNDARY = 0.1
PM_BOUNDARY = 1.0


@dataclass(frozen=True)
class Margins:
    """Stability margins of a loop gain L on a frequency grid; None where L does not cross.

    A gain margin of 0 dB or less is reported as it is (|L| >= 1 at -180 deg: the loop is at or
    beyond the stability boundary), as python-control's ``stability_margins`` does.
    """

    gain_margin_db: float | None  #: -20 log10 |L| at the phase crossover (-180 deg) [dB]
    phase_crossover_hz: float | None  #: [Hz]
    phase_margin_deg: float | None  #: 180 + arg L at the gain crossover [deg]
    crossover_hz: float | None  #: gain crossover |L| = 1 [Hz]
    delay_margin: float | None  #: PM / omega_c [s]: the extra delay the loop tolerates

    @property
    def verdict(self) -> str | None:
        """The loop's stability read from the margins' signs.

        As Nyquist's criterion reads them for a loop with one gain crossover and no unstable
        pole but its integrators (the laws ``rig tune`` designs).

        Returns
        -------
        str or None
            "unstable" (a margin below 0 by more than ``GM_BOUNDARY`` dB or ``PM_BOUNDARY``
            deg), "marginal" (one within that of 0), "stable" (both above), or None (not known:
            no gain crossover, and no gain margin at or below 0 dB).
        """
        gm, pm = self.gain_margin_db, self.phase_margin_deg
        if (pm is not None and pm < -PM_BOUNDARY) or (gm is not None and gm < -GM_BOUNDARY):
            return "unstable"
        if (pm is not None and abs(pm) <= PM_BOUNDARY) or (gm is not None and abs(gm) <= GM_BOUNDARY):
            return "marginal"
        return None if pm is None else "stable"

    def as_dict(self) -> dict[str, float | str | None]:
        """The margins as plain data.

        Returns
        -------
        dict
            Each field by its name (None where L does not cross), and ``verdict``.
        """
        return {
            "gain_margin_db": self.gain_margin_db,
            "phase_crossover_hz": self.phase_crossover_hz,
            "phase_margin_deg": self.phase_margin_deg,
            "crossover_hz": self.crossover_hz,
            "delay_margin": self.delay_margin,
            "verdict": self.verdict,
        }


def _cross(x: np.ndarray, y: np.ndarray, i: int, level: float) -> float:
    """x where y crosses ``level`` between samples i and i + 1 (linear in log x)."""
    lx = np.log(x[i : i + 2])
    s = (level - y[i]) / (y[i + 1] - y[i])
    return float(np.exp(lx[0] + s * (lx[1] - lx[0])))


def _at(f: np.ndarray, y: np.ndarray, i: int, fx: float) -> float:
    """y at ``fx`` between samples i and i + 1 (linear in log f)."""
    s = (math.log(fx) - math.log(f[i])) / (math.log(f[i + 1]) - math.log(f[i]))
    return float(y[i] + s * (y[i + 1] - y[i]))


def margins(f: np.ndarray, loop: np.ndarray) -> Margins:
    """The stability margins of a sampled loop gain.

    The gain crossover is the highest where |L| falls through 1; the gain margin is -20 log|L|
    where the phase falls through -180 deg (mod 360), the least where it does so several times
    (the first a growing gain takes to the boundary), negative where |L| > 1 there: the loop is
    then beyond the boundary. A phase rising through -180 deg at |L| > 1 (the low frequencies
    of a loop with more than two integrators, the cascade's) is a conditional stability's lower
    margin, not counted.

    Parameters
    ----------
    f : numpy.ndarray
        Increasing frequencies [Hz], > 0.
    loop : numpy.ndarray of complex
        The loop gain L at ``f``.

    Returns
    -------
    Margins
        The margins, None where L does not cross.
    """
    f = np.asarray(f, dtype=float)
    mag = 20.0 * np.log10(np.abs(loop))
    phase = np.degrees(np.unwrap(np.angle(loop)))
    crossover = pm = delay = None
    down = np.nonzero((mag[:-1] >= 0.0) & (mag[1:] < 0.0))[0]
    if len(down):
        i = int(down[-1])
        crossover = _cross(f, mag, i, 0.0)
        pm = float((_at(f, phase, i, crossover) + 180.0 + 180.0) % 360.0 - 180.0)
        delay = math.radians(pm) / (2.0 * math.pi * crossover)
    gm = phase_x = None
    for i in range(len(f) - 1):
        k = math.floor((phase[i] + 180.0) / 360.0)  # the -180 + 360 k line at or below phase[i]
        level = -180.0 + 360.0 * k
        if phase[i + 1] < level <= phase[i]:
            fx = _cross(f, phase, i, level)
            m = -_at(f, mag, i, fx)
            if gm is None or m < gm:
                gm, phase_x = m, fx
    return Margins(gm, phase_x, pm, crossover, delay)
