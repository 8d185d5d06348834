"""The (7.30) servo's linear mode closed around the DC motor with armature lag and a delay
(``controllers.servo_loop``), against loops built independently with python-control: the plant
discretised by ``control.sample_system`` (at the period, or at a fraction of it and composed over
the period for a delay that is part of one), the law as a discrete state-space system, the loop
closed by ``control.feedback`` (issue 35 item 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.design import design_dtsm
from controllers.servo_loop import ServoPlant, gain_edge, servo_loop_eigenvalues

control = pytest.importorskip("control")

A_M, B_M, LAM, H = 16.0, 680.0, -15.0, 16.0


def _design(dt: float):  # type: ignore[no-untyped-def]
    return design_dtsm(A=[[0.0, 1.0], [0.0, -A_M]], b=[0.0, -B_M], dt=dt, lam=LAM)


def _continuous(plant: ServoPlant):  # type: ignore[no-untyped-def]
    """The motor (3.4) as python-control's state space, its whole state measured: built from the
    physical constants of the dc-servo preset (R, L, k, J), not from (a_m, b_m, tau_e)."""
    if plant.tau_e == 0.0:
        a = [[0.0, 1.0], [0.0, -plant.a_m]]
        b = [[0.0], [plant.b_m]]
    else:  # k_e = k_t = a_m/b_m, R = 1 Ohm, L = tau_e R, J = k/(R b_m); state [theta, omega, i]
        k, r = plant.a_m / plant.b_m, 1.0
        lr, j = plant.tau_e * r, k / (r * plant.b_m)
        a = [[0.0, 1.0, 0.0], [0.0, 0.0, k / j], [0.0, -k / lr, -r / lr]]
        b = [[0.0], [0.0], [1.0 / lr]]
    n = len(a)
    return control.ss(a, b, np.eye(n), np.zeros((n, 1)))


def _law(design, h: float, n: int, scale: np.ndarray):  # type: ignore[no-untyped-def]
    """(7.30)'s linear mode as a discrete system from the measured state to u (positive feedback:
    u_k = F x_k - u_I,k-1, u_I,k = u_I,k-1 - h c x_k); ``scale`` maps the plant's state to
    [theta, omega, ...] (the current of the physical model is no state of the law)."""
    dt = design.dt
    c = np.zeros(n)
    c[:2] = design.c_delta
    k = np.zeros(n)
    k[:2] = design.c_delta_A_delta
    gain = (k + (1.0 / dt + h) * c) * scale
    if not h:  # no integral: a static gain (u_I stays 0)
        return control.ss(np.zeros((0, 0)), np.zeros((0, n)), np.zeros((1, 0)), [list(gain)], dt)
    return control.ss([[1.0]], [list(-h * c * scale)], [[-1.0]], [list(gain)], dt)


def _reference(design, h: float, plant: ServoPlant) -> np.ndarray:  # type: ignore[no-untyped-def]
    dt = design.dt
    sys = _continuous(plant)
    n = sys.nstates
    scale = np.ones(n)
    whole = round(plant.delay / dt)
    assert abs(plant.delay - whole * dt) < 1e-12 * dt, "whole periods here; a part of one below"
    discrete = control.sample_system(sys, dt, method="zoh")
    for _ in range(whole):  # z^-1 on the input per period
        discrete = control.series(control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], dt), discrete)
    loop = control.feedback(discrete, _law(design, h, n, scale), sign=1)
    return np.asarray(loop.poles())


def _same(a: np.ndarray, b: np.ndarray, tol: float = 1e-7) -> None:
    """The same eigenvalues up to ``tol``, the loop's structural zeros aside."""
    a = np.sort_complex(a[np.abs(a) > 1e-9])
    b = np.sort_complex(b[np.abs(b) > 1e-9])
    assert a.shape == b.shape, (a, b)
    assert np.allclose(a, b, atol=tol, rtol=0.0), (a, b)


@pytest.mark.parametrize("dt", [1e-4, 2e-3])
@pytest.mark.parametrize("tau_e", [0.0, 1e-4])
@pytest.mark.parametrize("k", [0.5, 3.0])
@pytest.mark.parametrize("h", [0.0, H])
def test_the_eigenvalues_are_python_control_s_loop_s(dt: float, tau_e: float, k: float, h: float) -> None:
    plant = ServoPlant(A_M, k * B_M, tau_e)
    _same(servo_loop_eigenvalues(_design(dt), h, plant), _reference(_design(dt), h, plant))


@pytest.mark.parametrize("periods", [1, 2])
def test_a_whole_period_s_delay_is_python_control_s_z_to_the_minus_one(periods: int) -> None:
    dt = 4e-4
    plant = ServoPlant(A_M, 1.3 * B_M, 1e-4, delay=periods * dt)
    _same(servo_loop_eigenvalues(_design(dt), H, plant), _reference(_design(dt), H, plant))


def test_a_delay_of_part_of_a_period_is_the_period_composed_of_sampled_substeps() -> None:
    """The plant sampled by python-control at T/8; over a period it sees u_k-1 for the first 3
    substeps (a delay of 3T/8) and u_k for the other 5: the period's map composed of them."""
    dt, parts, late = 4e-4, 8, 3
    plant = ServoPlant(A_M, 1.6 * B_M, 1e-4, delay=late * dt / parts)
    design = _design(dt)
    sub = control.sample_system(_continuous(plant), dt / parts, method="zoh")
    a_s, b_s = np.asarray(sub.A), np.asarray(sub.B)[:, 0]
    n = len(a_s)

    def held(steps: int) -> tuple[np.ndarray, np.ndarray]:
        phi, gamma = np.eye(n), np.zeros(n)
        for _ in range(steps):
            phi, gamma = a_s @ phi, a_s @ gamma + b_s
        return phi, gamma

    phi_late, gamma_late = held(late)
    phi_rest, gamma_rest = held(parts - late)
    phi, gamma_new, gamma_old = phi_rest @ phi_late, gamma_rest, phi_rest @ gamma_late
    c = np.zeros(n)
    c[:2] = design.c_delta
    k = np.zeros(n)
    k[:2] = design.c_delta_A_delta
    gain = k + (1.0 / dt + H) * c
    # state [x, u_I,k-1, u_k-1]
    m = np.zeros((n + 2, n + 2))
    now = np.concatenate([gain, [-1.0, 0.0]])
    m[:n, :n] = phi
    m[:n] += np.outer(gamma_new, now)
    m[:n, n + 1] += gamma_old
    m[n, :n], m[n, n] = -H * c, 1.0
    m[n + 1] = now
    # the physical model's current and the law's acceleration state differ by k_t/J: same spectrum
    _same(servo_loop_eigenvalues(design, H, plant), np.linalg.eigvals(m))


def test_the_lag_free_edge_is_7_30b_s_twice_the_design_s_b_m() -> None:
    """(7.30b) in its linear region: g_k+1 = (1 - k) g_k on a plant of k times the design's b_m
    (h = 0, no lag, no delay), so the loop has the eigenvalue 1 - k and its edge is k = 2."""
    design = _design(4e-4)
    for k in (0.5, 1.5, 1.9):
        values = servo_loop_eigenvalues(design, 0.0, ServoPlant(A_M, k * B_M))
        assert np.min(np.abs(values - (1.0 - k))) < 1e-3, values
    assert gain_edge(design, 0.0, ServoPlant(A_M, B_M)) == pytest.approx(2.0, abs=1e-3)
    assert gain_edge(design, H, ServoPlant(A_M, B_M)) == pytest.approx(1.994, abs=1e-3)


def test_the_armature_lag_moves_the_edge_and_a_period_s_delay_leaves_none() -> None:
    """The dc-servo preset's 0.1 ms armature lag at T = 0.4 ms: the edge at 3.85 times the design's
    b_m (python-control's loop on either side of it); a command applied at the next SYNC (a
    period's delay) makes the deadbeat reaching marginal at the design itself: g_k+1 = g_k - g_k-1,
    eigenvalues e^(+-j pi/3)."""
    design = _design(4e-4)
    plant = ServoPlant(A_M, B_M, 1e-4)
    edge = gain_edge(design, H, plant)
    assert edge == pytest.approx(3.848, abs=1e-3)
    for k, stable in ((edge * (1 - 1e-4), True), (edge * (1 + 1e-4), False)):
        radius = np.max(np.abs(_reference(design, H, ServoPlant(A_M, k * B_M, 1e-4))))
        assert bool(radius < 1.0) is stable, (k, radius)
    late = servo_loop_eigenvalues(design, 0.0, ServoPlant(A_M, B_M, 0.0, delay=4e-4))
    assert np.min(np.abs(late - np.exp(1j * math.pi / 3))) < 2e-3
    assert gain_edge(design, H, ServoPlant(A_M, B_M, 1e-4, delay=4e-4)) == 1.0
    assert gain_edge(design, H, ServoPlant(A_M, B_M), k_max=1.5) == math.inf
