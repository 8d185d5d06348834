"""Closed-loop behaviour the drives paper predicts, controller against the plant physics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.cascade import TABLE_V_CURRENT, TABLE_V_POSITION, TABLE_V_SPEED, CascadeLoop
from controllers.design import design_dtsm
from rig.papers.scenarios import cascade_run, position_servo_run, speed_loop_run
from rig.report.metrics import chattering_count, rms

LOAD = 1000.0  # f = T_L / J [rad/s^2]
TOL = 1e-9  # control increments below this count as zero [V]


@pytest.fixture(scope="module")
def servo_h16() -> object:
    return position_servo_run(load=LOAD, h=16.0)


def test_7_30_tracks_smooth_move_without_chattering(servo_h16: object) -> None:
    tr = servo_h16
    steady = tr.window(2.5)  # type: ignore[attr-defined]
    assert chattering_count(tr.u[steady], threshold=TOL) == 0  # type: ignore[attr-defined]
    assert np.max(np.abs(tr.error[tr.window(0.0, 1.5)])) < 2e-3  # type: ignore[attr-defined]


def test_7_30_with_h_has_zero_steady_state_error(servo_h16: object) -> None:
    tr = servo_h16
    assert abs(tr.error[-1]) < 1e-7  # type: ignore[attr-defined]
    assert np.max(np.abs(tr.error[tr.window(1.5, 2.0)])) > 1e-3  # type: ignore[attr-defined]


def test_7_30_without_h_has_the_theoretical_load_error() -> None:
    """h = 0: e_1 = T c_delta d_delta f / c_1 exactly, ~ T c_2 f / c_1 as the paper prints."""
    tr = position_servo_run(load=LOAD, h=0.0)
    d = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, -680.0], dt=0.4e-3, lam=-15.0)
    c1, c2 = d.c_delta
    # matched-disturbance channel d = [0, 1] of (7.28), ZOH to the delta form
    dd = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, 1.0], dt=0.4e-3, lam=-15.0).b_delta
    exact = d.dt * (c1 * dd[0] + c2 * dd[1]) * LOAD / c1
    printed = d.dt * c2 * LOAD / c1
    assert tr.error[-1] == pytest.approx(exact, rel=1e-9)
    assert tr.error[-1] == pytest.approx(printed, rel=1e-2)
    assert chattering_count(tr.u[tr.window(2.5)], threshold=TOL) == 0


def test_the_sign_law_chatters_by_the_same_metric() -> None:
    tr = position_servo_run(load=LOAD, law="relay")
    assert chattering_count(tr.u[tr.window(2.5)], threshold=TOL) > 100


def test_full_motor_agrees_with_reduced_model() -> None:
    reduced = position_servo_run(load=LOAD, t_end=1.2)
    full = position_servo_run(load=LOAD, t_end=1.2, full_motor=True)
    assert np.max(np.abs(full.y - reduced.y)) < 2e-4


@pytest.mark.parametrize("comp", ["none", "first", "second"])
def test_compensated_sliding_variable_is_the_predicted_difference_of_d(comp: str) -> None:
    """(6.23), (6.31), (6.34): g_{k+1} = T d_k; T (d_k - d_k-1) (alpha=1); T Delta^2 d (6.35)."""
    T = 1e-3
    tr = speed_loop_run(compensator=comp, alpha=1.0, held_disturbance=True, dt=T)
    g, d = tr.g, tr.extra["d"]
    if comp == "none":
        got, pred = g[2:], T * d[1:-1]
    elif comp == "first":
        got, pred = g[3:], T * (d[2:-1] - d[1:-2])
    else:
        got, pred = g[4:], T * (d[3:-1] - 2.0 * d[2:-2] + d[1:-3])
    assert np.max(np.abs(got)) > 1e-4
    assert np.max(np.abs(got - pred)) < 1e-15


def test_speed_error_shrinks_with_alpha_as_6_34_predicts() -> None:
    """For a slow disturbance (6.34) gives |g| ~ T |d'| T / alpha: the error falls as 1/alpha."""
    errs = {a: rms(speed_loop_run(compensator="first", alpha=a).y[2500:]) for a in (0.25, 0.5, 1.0)}
    none = rms(speed_loop_run(compensator="none").y[2500:])
    assert none > 10 * errs[0.25] > 10 * errs[0.5] / 2
    assert errs[0.25] / errs[0.5] == pytest.approx(2.0, rel=0.05)
    assert errs[0.5] / errs[1.0] == pytest.approx(2.0, rel=0.05)


@pytest.fixture(scope="module")
def cascade() -> object:
    return cascade_run(load=lambda t: 5.0 if t >= 2.0 else 0.0, t_end=4.0)


def test_cascade_outputs_bounded_by_u0(cascade: object) -> None:
    tr = cascade
    assert np.max(np.abs(tr.u)) <= TABLE_V_CURRENT.u0  # type: ignore[attr-defined]
    assert np.max(np.abs(tr.extra["i_ref"])) <= TABLE_V_SPEED.u0  # type: ignore[attr-defined]
    assert np.max(np.abs(tr.extra["omega_ref"])) <= TABLE_V_POSITION.u0  # type: ignore[attr-defined]
    assert np.max(np.abs(tr.extra["i_ref"])) == TABLE_V_SPEED.u0  # type: ignore[attr-defined]


def test_cascade_zero_steady_state_error_under_constant_load_and_no_chattering(
    cascade: object,
) -> None:
    tr = cascade
    steady = tr.window(3.5)  # type: ignore[attr-defined]
    assert np.max(np.abs(tr.error[steady])) < 1e-9  # type: ignore[attr-defined]
    assert chattering_count(tr.u[steady], threshold=TOL) == 0  # type: ignore[attr-defined]
    # the load is carried by the current: i_q = T_L / k_t
    k_t = 340.7439 * 0.0035
    assert tr.extra["i_q"][-1] == pytest.approx(5.0 / k_t, rel=1e-6)  # type: ignore[attr-defined]


def test_cascade_loop_kappa_of_table_v_is_chattering_free() -> None:
    for p in (TABLE_V_CURRENT, TABLE_V_SPEED, TABLE_V_POSITION):
        assert 0.0 < p.kappa <= 1.0


def test_cascade_loop_does_not_wind_up_after_saturation() -> None:
    """The integrator rises only until the output reaches U_0, then freezes; the output
    leaves the limit on the first sample after the error reverses."""
    p = TABLE_V_CURRENT
    loop = CascadeLoop(p)
    for _ in range(20_000):
        u = loop.step(1000.0, 0.0)  # unreachable current reference: saturated
    assert u == p.u0
    reach = p.k_r2 * p.u0  # the bounded reaching term far from the line
    assert p.u0 - reach <= loop.v <= p.u0 - reach + p.dt * p.k_int
    assert loop.step(0.0, 1.0) < p.u0


def test_cascade_tracks_the_move(cascade: object) -> None:
    tr = cascade
    assert np.max(np.abs(tr.error[tr.window(0.0, 2.0)])) < 5e-3  # type: ignore[attr-defined]
    assert math.isfinite(float(tr.y[-1]))  # type: ignore[attr-defined]
