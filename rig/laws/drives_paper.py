"""Constants of the drives paper (``papers/dtsm-electrical-drives.md``), in one place.

Section VII.B, the DC position servo: the motor (3.5) with a_m, b_m, sampled at
T, the design (7.31) with lambda, and the law (7.30) with sigma, q, rho, h.
Sections VII.C/VII.D, the induction motor IM1 (Table II), the integral DTSM
speed controller (Table IV), the cascade (Table V) and its load profile.
"""

from __future__ import annotations

__all__ = [
    "A_M",
    "B_IM",
    "B_M",
    "B_W",
    "J_IM",
    "LAMBDA_IDTSM",
    "LAMBDA_SERVO",
    "RHO",
    "SIGMA",
    "T_SERVO",
    "T_SPEED",
    "H",
    "Q",
    "vii_d_load",
]

A_M = 16.0  #: [1/s] (3.5), section VII.B
B_M = 680.0  #: [rad/(V s^2)] (3.5), section VII.B
T_SERVO = 0.4e-3  #: [s] sample period of the position servo, section VII.B
LAMBDA_SERVO = -15.0  #: [1/s] sliding eigenvalue of the design (7.31)
SIGMA = 10.0  #: [V] reaching bound of (7.30)
Q = 0.0  #: [V/(V s)] proportional reaching gain of (7.30)
RHO = 0.5  #: [rad/s] speed-error threshold of the integral in (7.30)
H = 16.0  #: [1/s] integral gain of (7.30)

J_IM = 0.0035  #: [kg m^2] IM1, Table II
B_IM = 0.0022  #: [N m s/rad] IM1 viscous friction, Table II
LAMBDA_IDTSM = -50.0  #: [1/s] the IDTSM speed controller, Table IV (lambda = 50)
B_W = 340.7439  #: [rad/(A s^2)] speed-loop b_w of Table V (so k_t = b_w J)
T_SPEED = 0.5e-3  #: [s] the speed loop's period, sections VII.C/VII.D


def vii_d_load(torque: float) -> str:
    """The load of section VII.D, T_L = T [h(t-2) - h(t-4) + h(t-8) sin(4 pi t)], as a profile
    (``drivers.profiles``) of ``torque`` T [N m] (the paper's T = 5 N m).

    Parameters
    ----------
    torque : float
        T [N m].

    Returns
    -------
    str
        The profile.
    """
    return f"pulse:{torque:g}:2:4 + sine:{torque:g}:2:8"
