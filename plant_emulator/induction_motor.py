"""Induction motor under indirect rotor-flux FOC, inside an emulated drive (drives paper, section IV).

Model: the two-axis IM of (4.1)-(4.3) with the mechanics (4.2) and (3.6),
written with complex space vectors in the stationary frame (x = x_alpha + j x_beta):

    sigma L_s di_s/dt = u_s - R_sigma i_s + (L_m/L_r)(1/T_r - j p_p omega_m) psi_r
    dpsi_r/dt = (L_m/T_r) i_s - (1/T_r - j p_p omega_m) psi_r
    T_e = (3/2) p_p (L_m/L_r) Im(conj(psi_r) i_s)                          (4.3)
    J domega_m/dt = T_e - B omega_m - T_L                                    (4.2)

and Coulomb friction with stiction beside B (``plant_emulator.friction``; ``ImParams.coulomb``).

with sigma = 1 - L_m^2/(L_s L_r), T_r = L_r/R_r, R_sigma = R_s + R_r L_m^2/L_r^2.
The printed A of (4.1) has misprints (its first row lacks 1/(sigma L_s), several
signs differ), so the standard model above is used; in the flux frame it is (4.1).

The drive: indirect FOC with slip (4.5) and the flux set-point (4.7), PI
current controllers of Table III at 0.1 ms (u = K_p e + K_i sum e, per axis,
limited to the converter's U_DC/sqrt(3)), integrated with RK4 on 4 sub-steps
per control step (compiled: ``plant_emulator.im_kernel``). Modes: CST (torque ->
i_qs* = T*/k_t, (4.8)), CSV/PV (the speed PI of Table III at the SYNC period), CSP
(position P on top).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drivers.maps.cia import Mode
from plant_emulator.axes import Axis, LoadProfile

__all__ = ["ImAxis", "ImParams"]

_CST, _CSV, _PV = Mode.CST, Mode.CSV, Mode.PROFILE_VELOCITY  # looked up once, compared every step


@dataclass(frozen=True)
class ImParams:
    """Table II (IM1) and Table III; SI units."""

    r_s: float = 5.45  #: [Ohm] stator resistance
    r_r: float = 3.1852  #: [Ohm] rotor resistance
    l_s: float = 0.4531  #: [H] stator inductance
    l_r: float = 0.4531  #: [H] rotor inductance
    l_m: float = 0.4413  #: [H] mutual inductance
    j: float = 0.0035  #: total inertia, IM1 with IM2 coupled [kg m^2]
    b: float = 0.0022  #: viscous friction B [N m s/rad] (Table II)
    #: Coulomb friction T_c [N m] (``plant_emulator.friction``), which Table II does not give:
    #: the ball bearings of the bench's two machines, by SKF's constant-coefficient estimate
    #: M = mu F d/2 with mu = 0.0015 (deep-groove ball bearings, SKF's rolling bearings
    #: catalogue, "Estimating the frictional moment"): 4 bearings of d = 25 mm (a 1.5 kW 2-pole
    #: frame-90 motor's) under half a ~2.5 kg rotor each (a rotor of J ~ 1.5e-3 kg m^2 and
    #: r ~ 35 mm) give ~1 mN m running; doubled for the start-up and seal friction the catalogues
    #: add (starting friction up to twice the running value)
    coulomb: float = 0.002
    p_p: int = 1  #: 2860 rpm at 50 Hz
    i_ds_ref: float = 2.35  #: flux current [A]: psi_r = L_m i_ds* = 1.04 Wb, about U_n sqrt(2)/omega_n
    current_kp: float = 22.3977  #: Table III
    current_ki: float = 0.87466  #: Table III, per 0.1 ms sample
    speed_kp: float = 0.4443  #: Table III [A s/rad]
    speed_ki: float = 0.0198  #: Table III [A/rad per sample]
    position_kp: float = 20.0  #: [1/s]
    u_dc: float = 560.0  #: [V]
    i_max: float = 3.25 * math.sqrt(2.0) * 2.0  #: |i_s| limit of the current references [A]
    foc_dt: float = 1e-4  #: [s]

    @property
    def k_t(self) -> float:
        """(4.8): k_t = (3 p_p/2)(L_m^2/L_r) i_ds* [N m/A]."""
        return 1.5 * self.p_p * self.l_m**2 / self.l_r * self.i_ds_ref


class ImAxis(Axis):
    """The IM and its FOC drive; see the module docstring.

    Parameters
    ----------
    p : ImParams
        The motor and its FOC drive.
    load : LoadProfile | None, optional
        Load torque [N m] of time [s]; None: no load.
    """

    modes = (Mode.CST, Mode.CSV, Mode.PROFILE_VELOCITY, Mode.CSP)

    def __init__(self, p: ImParams, *, load: LoadProfile | None = None) -> None:
        self.p = p
        self.load = load
        self.sigma = 1.0 - p.l_m**2 / (p.l_s * p.l_r)
        self.t_r = p.l_r / p.r_r
        self.r_sigma = p.r_s + p.r_r * p.l_m**2 / p.l_r**2
        self._k = self._constants()
        self._x = np.zeros(9)  #: the kernel's state (``im_kernel``)
        self._loads: dict[int, np.ndarray] = {}  #: T_L [N m] per FOC step, by steps per piece
        self.reset()

    def reset(self) -> None:
        self.i_s = 0j
        self.psi_r = 0j
        self.omega = 0.0
        self.theta = 0.0
        self.theta_e = 0.0  # FOC angle
        self.mode: int = Mode.CST
        self.command = 0.0
        self._int_d = self._int_q = 0.0
        self._int_w = 0.0
        self._i_q_speed = 0.0  # the speed PI's output, held over a SYNC period [A]
        self._speed_due = True  # the speed PI samples at the next piece of physics
        self._enabled = False
        self._u = 0j

    def latch(self) -> None:
        """A SYNC: the speed PI samples once per period, at its start."""
        self._speed_due = True

    def coast(self) -> None:
        self._enabled = False

    def release(self) -> None:
        self._int_d = self._int_q = self._int_w = 0.0
        self.coast()

    def set_command(self, mode: int, value: complex | float, *, computed_one_sync_ago: bool = False) -> None:
        if mode not in self.modes:
            raise ValueError(f"IM axis has no mode {mode}")
        self.mode, self.command = mode, float(value.real if isinstance(value, complex) else value)
        self._enabled = True

    def _constants(self) -> np.ndarray:
        """The kernel's constants (``im_kernel``'s indices), from the parameters; the kernel is
        imported (numba compiles it) with the first IM axis, not with the presets."""
        from plant_emulator import im_kernel as kernel

        self._foc_periods = kernel.foc_periods
        p, k = self.p, np.zeros(kernel.N)
        k[kernel.R_SIGMA], k[kernel.SIGMA_LS], k[kernel.LM_LR], k[kernel.T_R] = (
            self.r_sigma,
            self.sigma * p.l_s,
            p.l_m / p.l_r,
            self.t_r,
        )
        k[kernel.PP], k[kernel.B], k[kernel.J], k[kernel.KP], k[kernel.KI] = (
            p.p_p,
            p.b,
            p.j,
            p.current_kp,
            p.current_ki,
        )
        k[kernel.I_DS], k[kernel.U_MAX], k[kernel.I_LIMIT] = (
            p.i_ds_ref,
            p.u_dc / math.sqrt(3.0),
            p.i_max * 0.9,
        )
        k[kernel.SLIP], k[kernel.FOC_DT], k[kernel.LM_TR], k[kernel.COULOMB] = (
            1.0 / (self.t_r * p.i_ds_ref),
            p.foc_dt,
            p.l_m / self.t_r,
            p.coulomb,
        )
        return k

    def _i_q_ref(self) -> float:
        """i_qs* [A]: T*/k_t (4.8) in CST; else the speed PI of Table III, sampled once per SYNC
        period (a command later in the period waits for the next sample)."""
        p = self.p
        if self.mode == _CST:
            return self.command / p.k_t
        if not self._speed_due:
            return self._i_q_speed
        self._speed_due = False
        w_ref = self.command if self.mode in (_CSV, _PV) else p.position_kp * (self.command - self.theta)
        e = w_ref - self.omega
        i_q = p.speed_kp * e + self._int_w + p.speed_ki * e
        if abs(i_q) < p.i_max:
            self._int_w += p.speed_ki * e
        self._i_q_speed = i_q
        return i_q

    def advance(self, h: float, t: float) -> None:
        if h <= 0.0:
            return
        n = max(1, round(h / self.p.foc_dt))
        hs = h / n
        i_q_ref = self._i_q_ref() if self._enabled else 0.0
        loads = self._loads.get(n)
        if loads is None:
            loads = self._loads[n] = np.zeros(n)
        if self.load is not None:
            for k in range(n):
                loads[k] = self.load(t + k * hs)
        x = self._x
        x[0], x[1], x[2], x[3] = self.i_s.real, self.i_s.imag, self.psi_r.real, self.psi_r.imag
        x[4], x[5], x[6], x[7], x[8] = self.omega, self.theta, self.theta_e, self._int_d, self._int_q
        self._foc_periods(x, self._k, i_q_ref, self._enabled, hs, loads)
        self.i_s, self.psi_r = complex(x[0], x[1]), complex(x[2], x[3])
        self.omega, self.theta, self.theta_e = float(x[4]), float(x[5]), float(x[6])
        self._int_d, self._int_q = float(x[7]), float(x[8])

    @property
    def position(self) -> float:
        return self.theta

    @property
    def velocity(self) -> float:
        return self.omega

    @property
    def current(self) -> float:
        return abs(self.i_s)

    @property
    def torque(self) -> float:
        p = self.p
        return (
            1.5 * p.p_p * p.l_m / p.l_r * (self.psi_r.real * self.i_s.imag - self.psi_r.imag * self.i_s.real)
        )
