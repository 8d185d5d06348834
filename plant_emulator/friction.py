"""Coulomb friction with stiction at zero speed, for a fixed-step integrator (Karnopp's model).

The mechanics of (3.4) and (4.2) with a Coulomb friction torque T_f beside the viscous B w:

    J dw/dt = T_drive - B w - T_f,    T_drive = T_e - T_L (the motor's torque minus the load)

Integrated in steps of h with the inputs held (ZOH for the DC motor, RK4 for the IM), T_f is
held over each step like a load torque, chosen at the step's start (``held``):

- moving (w != 0): T_f = T_c sgn(w), against the motion;
- at rest (w == 0 exactly) while |T_drive| <= T_c: the shaft sticks, T_f = T_drive balances it,
  and after the step the speed is 0 and the angle where it was (``stuck``): no creeping, and no
  chattering of the sign of w around 0 as a bare T_c sgn(w) gives in fixed steps;
- at rest with |T_drive| > T_c: it breaks away, T_f = T_c sgn(T_drive).

Friction can stop the shaft, never drive it: a step that ends with w on the other side of zero
from the friction's direction ended at rest (``settle``: w = 0; the angle keeps what the step
made of it, at most |w| h off). The DC axis takes such a step again in parts, down to 0.1 us,
so that the friction turns where the shaft stops (``plant_emulator.axes.DcServoAxis._step``).
The breakaway torque (static friction) equals the kinetic one T_c: a datasheet gives one
figure (FAULHABER's "friction torque, static" C_o, which with the dynamic C_v n makes the
no-load current, I_0 k_M = C_o + C_v n_0).

Plain float functions, compiled by numba inside the IM's kernel (``plant_emulator.im_kernel``)
and called as Python by the DC axis (``plant_emulator.axes``).
"""

from __future__ import annotations

__all__ = ["held", "settle"]


def held(w: float, drive: float, coulomb: float) -> tuple[float, bool]:
    """The friction to hold over the next step.

    Parameters
    ----------
    w : float
        The speed at the step's start [rad/s].
    drive : float
        The torque driving the shaft there [N m].
    coulomb : float
        The Coulomb friction T_c [N m], >= 0.

    Returns
    -------
    tuple
        (T_f [N m], whether the shaft is stuck).
    """
    if w > 0.0:
        return coulomb, False
    if w < 0.0:
        return -coulomb, False
    if drive > coulomb:
        return coulomb, False
    if drive < -coulomb:
        return -coulomb, False
    return drive, True


def settle(w: float, friction: float) -> float:
    """The speed after a step that slipped with a friction held.

    Parameters
    ----------
    w : float
        The speed the step ended with [rad/s].
    friction : float
        The friction held over it [N m], not 0.

    Returns
    -------
    float
        ``w``, or 0 where it ended on the other side of zero from the friction's direction
        (it stopped within the step).
    """
    return w if w * friction > 0.0 else 0.0
