"""controllers.tuning: the PI from a bandwidth, the cascade from its bandwidths, the laws' linear
responses, and the margins against loops whose margins are known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers import tuning
from controllers.cascade import CascadeLoop
from controllers.design import design_dtsm
from controllers.pi import PI, PIParams
from controllers.position_servo import PositionServo, PositionServoParams


def test_margins_of_an_integrator_with_a_delay() -> None:
    """L = K e^(-s tau) / s: crossover K, PM = 90 deg - K tau, phase crossover pi/(2 tau),
    GM = -20 log10(2 K tau / pi), delay margin PM / K."""
    k, tau = 100.0, 2e-3
    f = np.geomspace(0.1, 1000.0, 20000)
    s = 2j * math.pi * f
    m = tuning.margins(f, k * np.exp(-s * tau) / s)
    assert m.crossover_hz == pytest.approx(k / (2 * math.pi), rel=1e-4)
    assert m.phase_margin_deg == pytest.approx(90.0 - math.degrees(k * tau), abs=0.01)
    assert m.phase_crossover_hz == pytest.approx(1.0 / (4 * tau), rel=1e-4)
    assert m.gain_margin_db == pytest.approx(-20 * math.log10(2 * k * tau / math.pi), abs=0.01)
    assert m.delay_margin == pytest.approx(math.radians(m.phase_margin_deg) / k, rel=1e-4)
    assert m.verdict == "stable"
    # beyond the boundary: |L| > 1 at the first -180 deg, a negative gain margin (was None)
    unstable = tuning.margins(f, 2000.0 * np.exp(-s * tau) / s)
    assert unstable.phase_margin_deg < 0.0 and unstable.verdict == "unstable"
    assert unstable.gain_margin_db == pytest.approx(-20 * math.log10(2 * 2000.0 * tau / math.pi), abs=0.01)
    assert unstable.phase_crossover_hz == pytest.approx(1.0 / (4 * tau), rel=1e-4)
    # at the boundary, K = pi / (2 tau): 0 dB at the phase crossover
    edge = tuning.margins(f, math.pi / (2 * tau) * np.exp(-s * tau) / s)
    assert edge.gain_margin_db == pytest.approx(0.0, abs=0.01) and edge.verdict == "marginal"


def test_pi_from_bandwidth_crosses_over_there_on_the_continuous_plant() -> None:
    a, b, fc = 16.0, 680.0, 25.0
    kp, ki = tuning.pi_from_bandwidth(a=a, b=b, bandwidth=2 * math.pi * fc)
    assert ki / kp == pytest.approx(a)
    f = np.geomspace(1.0, 1000.0, 5000)
    s = 2j * math.pi * f
    m = tuning.margins(f, (kp + ki / s) * b / (s + a))
    assert m.crossover_hz == pytest.approx(fc, rel=1e-3) and m.phase_margin_deg == pytest.approx(
        90.0, abs=0.1
    )
    with pytest.raises(ValueError, match="bandwidth = -1"):
        tuning.pi_from_bandwidth(a=a, b=b, bandwidth=-1.0)


def _response(u: list[float], dt: float, f: np.ndarray, size: float) -> np.ndarray:
    """C(z) at ``f`` from ``u``, a law's output to an impulse of ``size`` in one measurement
    at k = 0: the DTFT of its second difference (finite: at most two integrators in a law),
    divided by (1 - z^-1)^2."""
    d = np.diff(np.asarray(u), n=2, prepend=[0.0, 0.0])
    z = np.exp(2j * math.pi * np.asarray(f) * dt)
    k = np.arange(len(d))
    dtft = (d[None, :] * z[:, None] ** -k[None, :]).sum(axis=1)
    out: np.ndarray = dtft / (1.0 - 1.0 / z) ** 2 / size
    return out


F = np.geomspace(0.5, 1000.0, 40)  #: [Hz]


def test_the_linear_responses_are_the_laws_own() -> None:
    """Each law, run in its linear region on an impulse, has the response ``tuning`` gives it
    (u = -(C_theta theta + C_w w))."""
    dt, n = 4e-4, 400
    pi = PI(PIParams(kp=0.2, ki=3.0, dt=dt))
    u = [pi.step(-(1.0 if k == 0 else 0.0)) for k in range(n)]  # e = 0 - w
    assert -_response(u, dt, F, 1.0) == pytest.approx(tuning.pi_response(0.2, 3.0, dt, F), rel=1e-9)
    design = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, -680.0], dt=dt, lam=-15.0)
    expected = tuning.servo_response(design, 16.0, F)
    for j in (0, 1):  # theta, then w: e = -[theta, w]
        servo = PositionServo(PositionServoParams(design=design, sigma=1e9, q=0.0, rho=1e9, h=16.0, u0=1e9))
        e = np.zeros(2)
        u = []
        for k in range(n):
            e[:] = 0.0
            if k == 0:
                e[j] = -1e-6
            u.append(servo.step(e[0], e[1]))
        assert -_response(u, dt, F, 1e-6) == pytest.approx(expected[j], rel=1e-6)


def test_the_cascade_s_linear_response_is_the_loops_own() -> None:
    dt, n = 4e-4, 400
    speed, position = tuning.cascade_from_bandwidths(
        a=16.0,
        b=680.0,
        dt=dt,
        speed_bandwidth=2 * math.pi * 40,
        position_bandwidth=2 * math.pi * 5,
        u_max=1e9,
        speed_max=1e9,
    )
    expected = tuning.cascade_response(speed, position, 1.0, F)
    for j in (0, 1):
        outer, inner = CascadeLoop(position), CascadeLoop(speed)
        u = []
        for k in range(n):
            y = [0.0, 0.0]
            if k == 0:
                y[j] = 1e-7
            u.append(inner.step(outer.step(0.0, y[0], y[1]), y[1]))
        assert -_response(u, dt, F, 1e-7) == pytest.approx(expected[j], rel=1e-6)


@pytest.mark.parametrize("a,b,dt", [(16.0, 680.0, 4e-4), (0.63, 285.7, 5e-4)])
@pytest.mark.parametrize("fs,ratio", [(20.0, 10.0), (40.0, 8.0), (100.0, 10.0), (50.0, 5.0)])
def test_the_cascade_has_its_margins_on_3_5_with_a_period_of_delay(
    a: float, b: float, dt: float, fs: float, ratio: float
) -> None:
    from rig.identify.frequency import model_speed_response, model_velocity_response, speed_to_position

    speed, position = tuning.cascade_from_bandwidths(
        a=a,
        b=b,
        dt=dt,
        speed_bandwidth=2 * math.pi * fs,
        position_bandwidth=2 * math.pi * fs / ratio,
        u_max=10.0,
        speed_max=100.0,
    )
    f = np.geomspace(0.05, 0.4999 / dt, 4000)
    c_theta, c_w = tuning.cascade_response(speed, position, 1.0, f)
    p_theta = model_speed_response(a, b, dt, 1, f) * speed_to_position(f, dt)
    m = tuning.margins(f, c_theta * p_theta + c_w * model_velocity_response(a, b, dt, 1, f))
    assert 45.0 < m.phase_margin_deg < 75.0 and m.gain_margin_db > 9.0, m
