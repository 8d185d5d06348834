"""The RL plants of the dq-current paper: (29) as a recursion, and the fine stationary-frame model."""

from __future__ import annotations

import cmath
import math
import random

import pytest

from plant_emulator.rl_dq import ExactDqPlant, RLParams, StationaryRLConverter

L1, R1 = 6e-3, 0.36
TS = 1.0 / 1350.0
W = 2.0 * math.pi * 50.0


@pytest.mark.parametrize("m", [0.0, 0.3, 0.5, 1.0])
def test_recursion_is_the_transfer_function_29(m: float) -> None:
    """(29) as a difference equation:
    i_{k+2} - alpha_1 i_{k+1} = e^{-j w T_d}/(R + j w L) [(1 - alpha_2) u_{k+1} + (alpha_2 - alpha_1) u_k]."""
    rng = random.Random(7)
    plant = ExactDqPlant(RLParams(R1, L1, TS, m))
    u = [complex(rng.uniform(-50, 50), rng.uniform(-50, 50)) for _ in range(40)]
    i = [0j] + [plant.step(uk, W) for uk in u]
    a1 = math.exp(-TS * R1 / L1) * cmath.exp(-1j * W * TS)
    a2 = math.exp(-m * TS * R1 / L1) * cmath.exp(-1j * W * m * TS)
    c = cmath.exp(-1j * W * (1 - m) * TS) / complex(R1, W * L1)
    for k in range(len(u) - 1):
        rhs = a1 * i[k + 1] + c * ((1 - a2) * u[k + 1] + (a2 - a1) * u[k])
        assert i[k + 2] == pytest.approx(rhs, abs=1e-12)
    # and its transfer() is (29): at z = 1 it is K_s of (30)
    assert plant.transfer(1.0 + 0j, W) == pytest.approx(c)


def test_table_i_forms_for_s_pwm_middle() -> None:
    plant = ExactDqPlant(RLParams(R1, L1, TS, 0.5))
    a1 = math.exp(-TS * R1 / L1) * cmath.exp(-1j * W * TS)
    a2 = math.exp(-0.5 * TS * R1 / L1) * cmath.exp(-0.5j * W * TS)
    for z in (0.3 + 0.8j, -0.7 + 0.1j, 2.0 + 0j):
        table = (1 - a2) * (z + a2) / (z * (z - a1)) * cmath.exp(-0.5j * W * TS) / complex(R1, W * L1)
        assert plant.transfer(z, W) == pytest.approx(table, rel=1e-12)


@pytest.mark.parametrize("m", [0.0, 0.5])
def test_fine_model_equals_exact_at_zero_frame_speed(m: float) -> None:
    """With omega_k = 0 both models are the same physics: agree to rounding."""
    rng = random.Random(3)
    exact = ExactDqPlant(RLParams(R1, L1, TS, m))
    fine = StationaryRLConverter(RLParams(R1, L1, TS, m), n_sub=3)
    for _ in range(50):
        u = complex(rng.uniform(-20, 20), rng.uniform(-20, 20))
        e = complex(rng.uniform(-5, 5), 0.0)
        assert fine.step(u, 0.0, e) == pytest.approx(exact.step(u, 0.0, e), abs=1e-12)


def test_fine_model_does_not_depend_on_sub_steps() -> None:
    a = StationaryRLConverter(RLParams(R1, L1, TS, 0.5), n_sub=1)
    b = StationaryRLConverter(RLParams(R1, L1, TS, 0.5), n_sub=16)
    for k in range(100):
        u = complex(30.0, 10.0 * math.sin(k / 5))
        assert a.step(u, W, 200.0) == pytest.approx(b.step(u, W, 200.0), abs=1e-10)
    assert b.peak >= abs(b.i_ab) > 0.0


def _rk4_reference(u_dq: list[complex], e_dq: complex, m: float, per_sample: int = 400) -> list[complex]:
    """Brute-force alpha-beta RL with RK4: voltage u_k e^{j(theta_k + w T_s/2)} held from k T_s + T_d."""
    h = TS / per_sample
    t_d_steps = round((1 - m) * per_sample)
    i, out, held = 0j, [], 0j
    for k, u in enumerate(u_dq):
        new = u * cmath.exp(1j * (W * k * TS + W * TS / 2))
        for n in range(per_sample):
            v = held if n < t_d_steps else new
            t = k * TS + n * h

            def f(t: float, x: complex, v: complex = v) -> complex:
                return (v - R1 * x - e_dq * cmath.exp(1j * W * t)) / L1

            k1 = f(t, i)
            k2 = f(t + h / 2, i + h / 2 * k1)
            k3 = f(t + h / 2, i + h / 2 * k2)
            k4 = f(t + h, i + h * k3)
            i += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        held = new
        out.append(i * cmath.exp(-1j * W * (k + 1) * TS))
    return out


@pytest.mark.parametrize("m", [0.0, 0.5])
def test_fine_model_matches_a_brute_force_integration(m: float) -> None:
    u = [complex(200.0 + 5 * k, 40.0 - 3 * k) for k in range(25)]
    fine = StationaryRLConverter(RLParams(R1, L1, TS, m))
    got = [fine.step(uk, W, 230.0) for uk in u]
    for a, b in zip(got, _rk4_reference(u, 230.0, m)):
        assert a == pytest.approx(b, abs=1e-6)


def test_voltage_limit_bounds_the_applied_voltage() -> None:
    fine = StationaryRLConverter(RLParams(R1, L1, TS, 0.5), u_max=100.0)
    for _ in range(3000):
        i = fine.step(5000.0 + 0j, W)
    assert abs(i) == pytest.approx(100.0 / abs(complex(R1, W * L1)), rel=5e-3)


def test_exact_plant_follows_a_varying_frame_speed() -> None:
    """Coefficients are recomputed when omega_k changes; back to the old omega gives the old step."""
    p = ExactDqPlant(RLParams(R1, L1, TS, 0.5))
    p.step(10j, W)
    c_w = p._c
    p.step(10j, 2 * W)
    assert p._c != c_w
    p.step(10j, W)
    assert p._c == c_w


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(r1=-1.0, l1=L1, ts=TS),
        dict(r1=R1, l1=0.0, ts=TS),
        dict(r1=R1, l1=L1, ts=math.nan),
        dict(r1=R1, l1=L1, ts=TS, m=1.5),
    ],
)
def test_bad_parameters_are_named(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match=r"r1|l1|ts|m "):
        RLParams(**kwargs)
