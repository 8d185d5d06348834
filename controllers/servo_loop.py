"""The position servo (7.30) in its linear mode closed around a DC motor with armature lag and a
delay: the loop's eigenvalues, and the plant gain b_m at which they leave the unit circle.

Law. In its linear mode (min{v_k, w_k} = v_k of (7.30b), |e_2,k| <= rho of (7.30c)) with the
reference at rest, e_k = -x_k (x = [theta, omega], the design (7.28)), (7.30a-c) are

    u_k = (c_delta A_delta + (1/T + h) c_delta) x_k - u_I,k-1,   u_I,k = u_I,k-1 - h c_delta x_k

(``controllers.position_servo``; c_delta, c_delta A_delta of the design (6.16), (7.31)).

Plant. The DC motor (3.4) with k_e = k_t in SI, written with (3.5)'s a_m, b_m and the armature's
time constant tau_e = L_r/R_r; a = k_t i_r / J is the motor's acceleration:

    dtheta/dt = omega,   domega/dt = a,   da/dt = (b_m u - a_m omega - a) / tau_e,

which for tau_e -> 0 is (3.7) (and for tau_e = 0 it is (3.7) here). A viscous B is taken as part
of a_m (the dc-servo preset's B/J is 0.4 % of its a_m). The command of sample k acts from
kT + ``delay`` (the bus's: 0 for an RPDO applied on receipt in lock-step, its latency for one
applied after a latency, T for one applied at the next SYNC), held (ZOH) one period: with
delay = n T + tau (0 <= tau < T) the plant sees u_k-n-1 over [kT, kT + tau) and u_k-n over
[kT + tau, (k+1)T]:

    x_k+1 = Phi x_k + Gamma_1 u_k-n-1 + Gamma_0 u_k-n,
    Phi = e^(A T), Gamma_0 = int_0^(T-tau) e^(A s) ds B, Gamma_1 = e^(A (T-tau)) int_0^tau e^(A s) ds B.

The closed loop's state is [x_k (2 or 3 states), u_I,k-1 (where h > 0), u_k-1, ..., u_k-n-1]; its
eigenvalues are those of its transition matrix. For the lag-free plant without delay and h = 0 the sliding
variable obeys g_k+1 = (1 - k) g_k for a plant of k times the design's b_m (the analysis of
(7.30b) in its linear region): stable for 0 < k < 2. ``gain_edge`` finds that edge for any
plant: the least k >= 1 at which the spectral radius reaches 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from controllers.design import DTSMDesign

__all__ = ["ServoPlant", "gain_edge", "servo_loop_eigenvalues", "servo_loop_matrix"]


@dataclass(frozen=True)
class ServoPlant:
    """The DC motor the servo runs (module docstring); SI.

    Raises
    ------
    ValueError
        If a_m, b_m, tau_e or delay is not a finite number >= 0.
    """

    a_m: float  #: (3.5) [1/s]
    b_m: float  #: (3.5) [rad/(V s^2)]
    tau_e: float = 0.0  #: the armature's time constant L_r/R_r [s] (0: none, (3.7))
    delay: float = 0.0  #: from the sample to the command acting [s]

    def __post_init__(self) -> None:
        for name in ("a_m", "b_m", "tau_e", "delay"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} = {value!r}: expected a finite number >= 0")

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """The continuous plant's matrices.

        Returns
        -------
        tuple of numpy.ndarray
            (A, B), the state [theta, omega] (tau_e = 0) or [theta, omega, a].
        """
        if self.tau_e == 0.0:
            return np.array([[0.0, 1.0], [0.0, -self.a_m]]), np.array([0.0, self.b_m])
        t = self.tau_e
        a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, -self.a_m / t, -1.0 / t]])
        return a, np.array([0.0, 0.0, self.b_m / t])


def _held(a: np.ndarray, b: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^(A t), int_0^t e^(A s) ds B) from one exponential of [[A, B], [0, 0]] t (Van Loan)."""
    import scipy.linalg

    n = len(a)
    m = np.zeros((n + 1, n + 1))
    m[:n, :n], m[:n, n] = a, b
    e = scipy.linalg.expm(m * t)
    return e[:n, :n], e[:n, n]


def servo_loop_matrix(design: DTSMDesign, h: float, plant: ServoPlant) -> np.ndarray:
    """The transition matrix of (7.30)'s linear mode on ``plant`` (module docstring).

    Parameters
    ----------
    design : DTSMDesign
        (7.28)'s error-space design at its period T = design.dt.
    h : float
        (7.30c)'s integral gain [1/s].
    plant : ServoPlant
        The DC motor, its armature lag and the delay to the command.

    Returns
    -------
    numpy.ndarray
        The square matrix of x_k+1 = M x_k over the plant's state, u_I and the past commands.

    Raises
    ------
    ValueError
        If ``design`` is not the 2-state design.
    """
    if design.order != 2:
        raise ValueError("the servo loop needs the 2-state (error-space) design of (7.28)")
    dt = design.dt
    a, b = plant.matrices()
    n = len(a)
    whole = math.floor(plant.delay / dt + 1e-9)
    tau = max(0.0, plant.delay - whole * dt)
    tau = 0.0 if tau < 1e-9 * dt else tau
    phi_rest, gamma_0 = _held(a, b, dt - tau)  # [kT + tau, (k+1)T] under the newer command
    phi_tau, int_tau = _held(a, b, tau)
    phi, gamma_1 = phi_rest @ phi_tau, phi_rest @ int_tau  # [kT, kT + tau) under the older
    c = np.zeros(n)
    c[:2] = design.c_delta
    k = np.zeros(n)
    k[:2] = design.c_delta_A_delta
    gain = k + (1.0 / dt + h) * c  # u_k = gain x_k - u_I,k-1
    past = whole + 1  # u_k-1 .. u_k-whole-1 kept
    integral = 1 if h else 0  # with h = 0, u_I stays 0: no state (its eigenvalue 1 is no mode)
    size = n + integral + past
    m = np.zeros((size, size))
    ui, u = n, n + integral  # the columns of u_I,k-1 and of u_k-1 (then u_k-2, ...)
    # the command of this sample, as a row over the state: u_k = gain x_k - u_I,k-1
    now = np.zeros(size)
    now[:n] = gain
    if integral:
        now[ui] = -1.0
    # x_k+1 = Phi x_k + Gamma_0 u_k-n + Gamma_1 u_k-n-1
    m[:n, :n] = phi
    newer = now if whole == 0 else np.eye(size)[u + whole - 1]
    m[:n] += np.outer(gamma_0, newer)
    m[:n, u + whole] += gamma_1
    if integral:  # u_I,k = u_I,k-1 - h c x_k
        m[ui, :n], m[ui, ui] = -h * c, 1.0
    # the commands shift: u_k becomes the newest past one
    m[u] = now
    for i in range(1, past):
        m[u + i, u + i - 1] = 1.0
    return m


def servo_loop_eigenvalues(design: DTSMDesign, h: float, plant: ServoPlant) -> np.ndarray:
    """The eigenvalues of ``servo_loop_matrix`` (stable: all inside the unit circle).

    Parameters
    ----------
    design : DTSMDesign
        (7.28)'s error-space design.
    h : float
        (7.30c)'s integral gain [1/s].
    plant : ServoPlant
        The DC motor, its armature lag and the delay to the command.

    Returns
    -------
    numpy.ndarray of complex
        The closed loop's eigenvalues.
    """
    values: np.ndarray = np.linalg.eigvals(servo_loop_matrix(design, h, plant))
    return values


def _radius(design: DTSMDesign, h: float, plant: ServoPlant, k: float) -> float:
    return float(np.max(np.abs(servo_loop_eigenvalues(design, h, replace(plant, b_m=k * plant.b_m)))))


def gain_edge(
    design: DTSMDesign, h: float, plant: ServoPlant, *, k_max: float = 16.0, step: float = 0.05
) -> float:
    """The least k >= 1 for which (7.30)'s linear mode on ``plant`` with k times its b_m has an
    eigenvalue on the unit circle (the plants of b_m from ``plant.b_m`` up to that are stable).

    Parameters
    ----------
    design : DTSMDesign
        (7.28)'s error-space design.
    h : float
        (7.30c)'s integral gain [1/s].
    plant : ServoPlant
        The DC motor, its armature lag and the delay to the command.
    k_max : float
        The largest k looked at.
    step : float
        The scan's step in k from 1, before a bisection to 1e-9.

    Returns
    -------
    float
        The edge k; 1.0 where the loop is unstable already at k = 1, ``math.inf`` where it stays
        stable up to ``k_max``.
    """
    if _radius(design, h, plant, 1.0) >= 1.0:
        return 1.0
    low = 1.0
    while low < k_max:
        high = min(low + step, k_max)
        if _radius(design, h, plant, high) >= 1.0:
            while high - low > 1e-9:
                mid = 0.5 * (low + high)
                low, high = (low, mid) if _radius(design, h, plant, mid) >= 1.0 else (mid, high)
            return high
        low = high
    return math.inf
