"""DTSM laws (6.14), (6.15a/b), IDTSM (6.20)-(6.21), compensators (6.30b), (6.35), PI."""

from __future__ import annotations

import math

import pytest

from controllers.compensators import FirstOrderCompensator, SecondOrderCompensator
from controllers.design import design_dtsm
from controllers.dtsm import DTSM, DTSMParams
from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from plant_emulator.dc_motor import ReducedDCMotor

SERVO = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, -680.0], dt=0.4e-3, lam=-15.0)
SPEED = design_dtsm(A=[[-16.0]], b=[680.0], dt=1e-3, lam=-1.0)


def test_6_14_is_deadbeat_on_the_delta_model() -> None:
    """With (6.14) the next sliding variable is zero from any state (6.13)."""
    ctl = DTSM(DTSMParams(design=SERVO, law="deadbeat"))
    (a11, a12), (a21, a22) = SERVO.A_delta
    b1, b2 = SERVO.b_delta
    T = SERVO.dt
    e1, e2 = 0.3, -2.0
    u = ctl.step(e1, e2)
    n1 = e1 + T * (a11 * e1 + a12 * e2 + b1 * u)
    n2 = e2 + T * (a21 * e1 + a22 * e2 + b2 * u)
    c1, c2 = SERVO.c_delta
    assert abs(ctl.g) > 1e-4
    assert c1 * n1 + c2 * n2 == pytest.approx(0.0, abs=1e-12)


def test_6_15a_bounds_the_reaching_control_and_is_6_14_near_the_line() -> None:
    bounded = DTSM(DTSMParams(design=SERVO, law="bounded", sigma=10.0))
    deadbeat = DTSM(DTSMParams(design=SERVO, law="deadbeat"))
    k1, _k2 = SERVO.c_delta_A_delta
    u = bounded.step(1.0, 0.0)  # far from the line: |g|/T = 55 > sigma
    assert u == pytest.approx(-(k1 * 1.0) + 10.0)
    assert bounded.step(1e-5, 0.0) == pytest.approx(deadbeat.step(1e-5, 0.0), rel=1e-12)


def test_6_15b_saturates_at_u0() -> None:
    ctl = DTSM(DTSMParams(design=SERVO, law="saturated", u0=12.0))
    assert ctl.step(5.0, 0.0) == 12.0
    assert ctl.step(-5.0, 0.0) == -12.0
    small = DTSM(DTSMParams(design=SERVO, law="deadbeat")).step(1e-6, 0.0)
    assert ctl.step(1e-6, 0.0) == pytest.approx(small)


def test_reset_restores_initial_state() -> None:
    ctl = DTSM(DTSMParams(design=SPEED, law="deadbeat"), FirstOrderCompensator(1.0, 1e-3))
    first = [ctl.step(x) for x in (1.0, 0.5, 0.1)]
    ctl.reset()
    assert [ctl.step(x) for x in (1.0, 0.5, 0.1)] == first


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"law": "bang"}, "law"),
        ({"sigma": 0.0}, "sigma"),
        ({"u0": -1.0}, "u0"),
        ({"law": "relay"}, "sigma"),
    ],
)
def test_bad_dtsm_params(params: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        DTSMParams(design=SERVO, **params)  # type: ignore[arg-type]


def test_first_order_compensator_transfer_function_6_33() -> None:
    """Impulse response of (6.30b) is -alpha/T for every k (the integrator of (6.33))."""
    comp = FirstOrderCompensator(alpha=0.5, dt=1e-3)
    out = [comp.step(g) for g in (1.0, 0.0, 0.0, 0.0)]
    assert out == pytest.approx([-500.0] * 4)


def test_second_order_compensator_transfer_function_6_35() -> None:
    """Impulse response of -(2z-1)z/(T(z-1)^2) is -(k+2)/T... i.e. -(2, 3, 4, 5)/T."""
    comp = SecondOrderCompensator(dt=1e-3)
    out = [comp.step(g) for g in (1.0, 0.0, 0.0, 0.0)]
    assert out == pytest.approx([-2000.0, -3000.0, -4000.0, -5000.0])


@pytest.mark.parametrize("alpha", [0.0, 2.0, -0.1, math.nan])
def test_compensator_alpha_range(alpha: float) -> None:
    with pytest.raises(ValueError, match="alpha"):
        FirstOrderCompensator(alpha=alpha, dt=1e-3)


def _idtsm_run(load_f: float, steps: int = 3000) -> tuple[list[float], IDTSM]:
    ctl = IDTSM(IDTSMParams(a=-16.0, b=680.0, dt=1e-3, lam=-50.0))
    motor = ReducedDCMotor(a_m=16.0, b_m=680.0, dt=1e-3)
    errors = []
    for k in range(steps):
        e = 20.0 - motor.omega
        errors.append(e)
        motor.step(ctl.step(e), f=load_f if k >= 1000 else 0.0)
    return errors, ctl


def test_idtsm_6_21_error_decays_at_lambda_delta_on_the_line() -> None:
    errors, ctl = _idtsm_run(0.0)
    ratio = 1.0 + ctl.params.dt * ctl.lambda_delta
    # the initial state is on the line (Remark 4): e_{k+1} = (1 + T lambda_delta) e_k from the start
    for k in range(1, 30):
        assert errors[k + 1] == pytest.approx(ratio * errors[k], rel=1e-6, abs=1e-12)


def test_idtsm_has_no_steady_state_error_under_constant_disturbance() -> None:
    errors, _ctl = _idtsm_run(-2.0)
    assert abs(errors[-1]) < 1e-9
    assert max(abs(e) for e in errors[1000:]) > 1e-3  # the disturbance did act


def test_idtsm_k_eq_is_6_21() -> None:
    ctl = IDTSM(IDTSMParams(a=-16.0, b=680.0, dt=1e-3, lam=-50.0))
    assert ctl.k_eq == pytest.approx((ctl.a_delta - ctl.lambda_delta) / ctl.b_delta)


def test_pi_anti_windup_recovers_without_overshoot_of_the_integrator() -> None:
    pi = PI(PIParams(kp=1.0, ki=100.0, dt=1e-3, u_max=1.0, u_min=-1.0))
    for _ in range(1000):
        u = pi.step(10.0)  # saturated for a long time
    assert u == 1.0
    assert pi.integral == 0.0  # p alone saturates: the integrator never winds up
    # the error reverses: the output leaves saturation at once, not after unwinding
    assert pi.step(-0.5) < 1.0


def test_pi_without_limits_is_textbook() -> None:
    pi = PI(PIParams(kp=2.0, ki=10.0, dt=0.1))
    assert [pi.step(1.0) for _ in range(3)] == pytest.approx([2.0, 3.0, 4.0])
