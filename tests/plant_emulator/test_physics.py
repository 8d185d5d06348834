"""DC motor (3.4)-(3.7), exact ZOH stepping and the encoder."""

from __future__ import annotations

import math

import pytest
from scipy.integrate import solve_ivp

from plant_emulator.axes import DcServoAxis, ServoLoops
from plant_emulator.dc_motor import DCMotor, DCMotorParams, ReducedDCMotor
from plant_emulator.encoder import Encoder
from plant_emulator.zoh import LinearZOH


def test_reduced_motor_matches_closed_form_speed_and_angle() -> None:
    a_m, b_m, u, dt = 16.0, 680.0, 1.5, 1e-3
    m = ReducedDCMotor(a_m=a_m, b_m=b_m, dt=dt)
    for _ in range(250):
        m.step(u)
    t = 0.25
    w_inf = b_m * u / a_m
    assert m.omega == pytest.approx(w_inf * (1.0 - math.exp(-a_m * t)), rel=1e-12)
    assert m.theta == pytest.approx(w_inf * (t - (1.0 - math.exp(-a_m * t)) / a_m), rel=1e-12)


def test_step_size_does_not_change_the_exact_solution() -> None:
    coarse, fine = (
        ReducedDCMotor(a_m=16.0, b_m=680.0, dt=1e-3),
        ReducedDCMotor(a_m=16.0, b_m=680.0, dt=1e-4),
    )
    for _k in range(100):
        coarse.step(1.0, t_load=0.5)
        for _ in range(10):
            fine.step(1.0, t_load=0.5)
    assert fine.theta == pytest.approx(coarse.theta, rel=1e-11)


def test_full_motor_steady_state_and_reduced_parameters() -> None:
    p = DCMotorParams(r_r=2.0, l_r=5e-3, k_e=0.1, k_t=0.1, j=1e-4, b=1e-5)
    assert p.a_m == pytest.approx(0.1 * 0.1 / (1e-4 * 2.0))
    assert p.b_m == pytest.approx(0.1 / (1e-4 * 2.0))
    m = DCMotor(p, dt=1e-4)
    u, t_load = 12.0, 0.02
    for _ in range(40_000):
        m.step(u, t_load)
    # steady state of (3.4): k_t i = B w + T_L and u = R i + k_e w
    i = (p.b * u / p.k_e + t_load) / (p.k_t + p.b * p.r_r / p.k_e)
    w = (u - p.r_r * i) / p.k_e
    assert m.current == pytest.approx(i, rel=1e-9)
    assert m.omega == pytest.approx(w, rel=1e-9)


def test_from_am_bm_gives_those_parameters() -> None:
    p = DCMotorParams.from_am_bm(a_m=23.5, b_m=412.0)
    assert (p.a_m, p.b_m) == pytest.approx((23.5, 412.0))


@pytest.mark.parametrize("field", ["r_r", "l_r", "j", "k_t"])
def test_bad_motor_parameters_named(field: str) -> None:
    kwargs = {"r_r": 1.0, "l_r": 1e-3, "k_e": 0.1, "k_t": 0.1, "j": 1e-4}
    kwargs[field] = 0.0 if field != "k_t" else -1.0
    with pytest.raises(ValueError, match=field):
        DCMotorParams(**kwargs)


def test_zoh_rejects_bad_dt() -> None:
    with pytest.raises(ValueError, match="dt"):
        LinearZOH([[0.0]], [[1.0]], 0.0)


def test_encoder_quantises_and_differentiates() -> None:
    enc = Encoder(4096, dt=1e-3)
    q = 2.0 * math.pi / 4096
    pos, vel = enc.sample(10.5 * q)
    assert (pos, vel) == (10 * q, 0.0)
    pos, vel = enc.sample(13.99 * q)
    assert pos == pytest.approx(13 * q)
    assert vel == pytest.approx(3 * q / 1e-3)
    pos, _ = enc.sample(-0.1 * q)
    assert pos == pytest.approx(-q)  # floor, also below zero


@pytest.mark.parametrize("cpr", [0, -5, 2.5])
def test_encoder_rejects_bad_resolution(cpr: float) -> None:
    with pytest.raises(ValueError, match="counts_per_rev"):
        Encoder(cpr, dt=1e-3)  # type: ignore[arg-type]


def test_dc_servo_axis_coasts_with_the_armature_open() -> None:
    """Power stage off: i_r = 0 and J dw/dt = -B w - T_L, whatever the back-EMF."""
    p = DCMotorParams(r_r=1.0, l_r=1e-4, k_e=0.05, k_t=0.05, j=1e-4, b=2e-4)
    axis = DcServoAxis(p, ServoLoops(1.0, 1.0, 1.0, 1.0, 48.0), inner_dt=1e-4, load=lambda t: 0.01)
    axis.x[:] = [0.0, 100.0, 3.0]
    axis.coast()
    for k in range(50):
        axis.advance(1e-3, k * 1e-3)
    ref = solve_ivp(
        lambda t, y: [y[1], (-p.b * y[1] - 0.01) / p.j], (0.0, 0.05), [0.0, 100.0], rtol=1e-12, atol=1e-12
    )
    assert axis.current == 0.0
    assert axis.velocity == pytest.approx(ref.y[1, -1], rel=1e-9)
    assert axis.position == pytest.approx(ref.y[0, -1], rel=1e-9)
