"""The complex-vector current controller (32)-(37) and the dq PI baseline."""

from __future__ import annotations

import cmath
import math

import pytest

from controllers.dq_current import (
    ComplexVectorCurrentController,
    DqCurrentParams,
    DqPI,
    DqPIParams,
    dead_time_fraction,
    pi_gains_like,
)
from plant_emulator.rl_dq import ExactDqPlant, RLParams, StationaryRLConverter

L1, R1 = 6e-3, 0.36
W = 2.0 * math.pi * 50.0


def _ts(ratio: float) -> float:
    return ratio / 50.0


@pytest.mark.parametrize("strategy", ["s-pwm-start", "a-pwm-double", "s-pwm-middle"])
@pytest.mark.parametrize("ratio", [1 / 27, 1 / 51])
def test_gain_is_34_and_37_as_printed(strategy: str, ratio: float) -> None:
    ts, g = _ts(ratio), 0.3
    c = ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g, strategy))
    tau = L1 / R1
    if strategy == "s-pwm-middle":
        b0, ang = math.exp(-0.5 * ts / tau), 0.5 * W * ts
    else:
        b0, ang = math.exp(-ts / tau), W * ts
    k0 = g * R1 / (b0**2 - 2 * b0 * math.cos(ang) + 1)
    k_printed = k0 * (1 + 1j * W * tau) * complex(1 - b0 * math.cos(ang), -b0 * math.sin(ang))
    k_rz, z0, rot = c.gains(W)
    assert k_rz == pytest.approx(k_printed, rel=1e-12)
    assert z0 == pytest.approx(math.exp(-ts / tau) * cmath.exp(-1j * W * ts))  # (33)
    assert rot == pytest.approx(cmath.exp(1j * W * (1 - dead_time_fraction(strategy)) * ts))


@pytest.mark.parametrize("strategy", ["s-pwm-start", "a-pwm-double", "s-pwm-middle"])
def test_open_loop_is_35_and_38(strategy: str) -> None:
    ts, g = _ts(1 / 27), 0.35
    c = ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g, strategy))
    plant = ExactDqPlant(RLParams(R1, L1, ts, dead_time_fraction(strategy)))
    beta1 = math.exp(-0.5 * ts * R1 / L1) * cmath.exp(-0.5j * W * ts)  # (38) with the j
    for z in (0.5 + 0.5j, -0.3 + 0.9j, 1.5 - 0.2j):
        expected = g / (z * z - z) if strategy != "s-pwm-middle" else g * (z + beta1) / (z * z - z)
        assert c.transfer(z, W) * plant.transfer(z, W) == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize(
    "strategy,ratio", [("s-pwm-start", 1 / 27), ("s-pwm-start", 1 / 51), ("a-pwm-double", 1 / 30)]
)
def test_q_step_is_36_with_exactly_zero_d_current(strategy: str, ratio: float) -> None:
    ts, g = _ts(ratio), 0.35
    c = ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g, strategy))
    plant = ExactDqPlant(RLParams(R1, L1, ts, 0.0))
    y = [0.0, 0.0]  # (36): y_n = y_{n-1} - gamma y_{n-2} + gamma r_{n-2}, r_n = 1 for n >= 0
    while len(y) < 62:
        y.append(y[-1] - g * y[-2] + g)
    i = 0j
    for k in range(60):
        i = plant.step(c.step(1j, i, W), W)  # i_{k+1}
        assert abs(i.real) < 1e-12
        assert i.imag == pytest.approx(y[k + 1], abs=1e-12)


def _peak_d(controller: object, plant: object, steps: int = 80) -> float:
    i, peak = 0j, 0.0
    for _ in range(steps):
        i = plant.step(controller.step(1j, i, W), W)  # type: ignore[attr-defined]
        peak = max(peak, abs(i.real))
    return peak


def test_pi_baseline_does_couple_and_feed_forward_helps_partly() -> None:
    ts, g = _ts(1 / 27), 0.35
    k_p, k_i = pi_gains_like(R1, L1, ts, g)
    pi = _peak_d(DqPI(DqPIParams(k_p, k_i)), ExactDqPlant(RLParams(R1, L1, ts)))
    pid = _peak_d(DqPI(DqPIParams(k_p, k_i, l1=L1, decouple=True)), ExactDqPlant(RLParams(R1, L1, ts)))
    prop = _peak_d(
        ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g)), ExactDqPlant(RLParams(R1, L1, ts))
    )
    assert pi > 0.3 and 0.1 < pid < pi and prop < 1e-12


def test_pi_like_equals_proposed_at_zero_frame_speed() -> None:
    ts, g = _ts(1 / 27), 0.3
    k_p, k_i = pi_gains_like(R1, L1, ts, g)
    a, b = DqPI(DqPIParams(k_p, k_i)), ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g))
    for k in range(20):
        i = complex(0.1 * k, -0.05 * k)
        assert a.step(1j, i, 0.0) == pytest.approx(b.step(1j, i, 0.0), abs=1e-12)


def test_fine_plant_needs_the_mid_interval_angle() -> None:
    """In alpha-beta hold, the reference turned at theta_k lags by w T_s/2: 7-10 % d peak at 1/27."""
    ts, g = _ts(1 / 27), 0.35
    peaks = {}
    for angle in ("middle", "sample"):
        plant = StationaryRLConverter(RLParams(R1, L1, ts, 0.0), hold_angle=angle)
        peaks[angle] = _peak_d(ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g)), plant)
    assert peaks["middle"] < 0.002
    assert 0.07 < peaks["sample"] < 0.10


def test_frame_speed_may_change_every_step() -> None:
    """A frequency ramp 1/51 -> 1/27 of omega_s over 1000 samples: the gains follow and the
    q step stays decoupled (a ramp over 100 samples gives a 2 % d peak: the changing pole)."""
    ts, g = _ts(1 / 51), 0.35
    c = ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g))
    plant = ExactDqPlant(RLParams(R1, L1, ts))
    i, peak = 0j, 0.0
    for k in range(1100):
        w = W * (1.0 + 0.9 * min(k, 1000) / 1000)
        i = plant.step(c.step(1j, i, w), w)
        peak = max(peak, abs(i.real))
    assert peak < 0.005
    assert i == pytest.approx(1j, abs=1e-3)


@pytest.mark.parametrize("kind", ["proposed", "pi-decoupled"])
def test_anti_windup_recovers_where_an_outside_clip_does_not(kind: str) -> None:
    """300 samples at the voltage limit chasing an unreachable 100 A, then 5 A: with the
    limit inside the controller the error falls below 2 A within 80 samples; with the same
    controller unlimited and its output clipped outside (wound-up integral) it stays > 20 A."""
    ts, g, u_max = _ts(1 / 27), 0.3, 60.0
    k_p, k_i = pi_gains_like(R1, L1, ts, g)
    final = {}
    for inside in (True, False):
        limit = u_max if inside else math.inf
        if kind == "proposed":
            ctl: object = ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, g, u_max=limit))
        else:
            ctl = DqPI(DqPIParams(k_p, k_i, l1=L1, decouple=True, u_max=limit))
        plant, i = ExactDqPlant(RLParams(R1, L1, ts)), 0j
        for k in range(380):
            u = ctl.step(100j if k < 300 else 5j, i, W)  # type: ignore[attr-defined]
            if abs(u) > u_max:
                u *= u_max / abs(u)
            i = plant.step(u, W)
        final[inside] = abs(i - 5j)
    assert final[True] < 2.0
    assert final[False] > 20.0


def test_source_voltage_is_rejected_by_the_integral() -> None:
    ts = _ts(1 / 27)
    c = ComplexVectorCurrentController(DqCurrentParams(R1, L1, ts, 0.3, "s-pwm-middle"))
    plant = StationaryRLConverter(RLParams(R1, L1, ts, 0.5))
    i = 0j
    for _ in range(400):
        i = plant.step(c.step(10 - 5j, i, W), W, 325.0)
    assert i == pytest.approx(10 - 5j, abs=1e-3)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(r1=R1, l1=L1, ts=1e-3, gamma=0.0), "gamma"),
        (dict(r1=R1, l1=L1, ts=1e-3, gamma=0.3, strategy="svpwm"), "svpwm"),
        (dict(r1=R1, l1=L1, ts=1e-3, gamma=0.3, u_max=math.nan), "u_max"),
        (dict(r1=-0.1, l1=L1, ts=1e-3, gamma=0.3), "r1"),
    ],
)
def test_bad_parameters_are_named(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        DqCurrentParams(**kwargs)  # type: ignore[arg-type]
