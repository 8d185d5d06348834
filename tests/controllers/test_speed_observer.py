"""The speed observer of (3.5) with a disturbance state: from a quantised position to a speed far
finer than the Euler difference's quantum, unbiased under a constant load, and the VII.B servo
on a 4096-count encoder within 2x of the exact-measurement simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.discretize import zoh
from controllers.speed_observer import SpeedObserver
from rig.papers.scenarios import position_servo_run
from rig.report.metrics import rms

A_M, B_M, T = 16.0, 680.0, 0.4e-3
QUANTUM = 2.0 * math.pi / 4096  #: [rad] one count


def _track(load: float) -> tuple[np.ndarray, SpeedObserver]:
    """The model driven by a sine-plus-offset voltage and a load ``load`` [rad/s^2] from 1 s;
    the observer on the counted position. The speed errors after 0.4 s."""
    phi, gamma = zoh([[0.0, 1.0], [0.0, -A_M]], [[0.0, 0.0], [B_M, 1.0]], dt=T)  # inputs u and -T_L/J
    obs = SpeedObserver(A_M, B_M, dt=T, bandwidth=500.0)
    x, errors = np.zeros(2), []
    for k in range(5000):
        u = 3.0 + 2.0 * math.sin(2.0 * math.pi * 2.0 * k * T)
        w = obs.update(math.floor(x[0] / QUANTUM) * QUANTUM)
        obs.command(u)
        errors.append(w - x[1])
        x = phi @ x + gamma @ np.array([u, -load if k * T >= 1.0 else 0.0])
    return np.array(errors[1000:]), obs


def test_the_speed_is_finer_than_the_euler_quantum() -> None:
    errors, _ = _track(load=0.0)
    euler_quantum = QUANTUM / T  # 3.8 rad/s
    assert rms(errors) < euler_quantum / 20, rms(errors)


def test_a_constant_load_biases_nothing() -> None:
    errors, obs = _track(load=1000.0)
    assert abs(np.mean(errors[-1000:])) < 0.05  # rad/s over the last 0.4 s
    assert obs.disturbance == pytest.approx(-1000.0, rel=0.05)  # d = -T_L/J


def test_the_servo_on_a_4096_count_encoder() -> None:
    """Euler-backward speed: more than 5x the exact simulation's rms error and volts of command
    ripple; the observer: within 2x and a ripple below 0.5 V."""
    run = {"load": 1000.0, "full_motor": True, "t_end": 3.0}
    exact = position_servo_run(**run)
    euler = position_servo_run(counts_per_rev=4096, **run)
    observed = position_servo_run(counts_per_rev=4096, observer_bandwidth=500.0, **run)

    def ripple(tr):  # type: ignore[no-untyped-def]
        return rms(np.diff(tr.u[tr.window(2.5)]))

    assert rms(euler.error) > 5 * rms(exact.error) and ripple(euler) > 1.0
    assert rms(observed.error) < 2 * rms(exact.error) and ripple(observed) < 0.5


@pytest.mark.parametrize(
    ("kw", "words"), [({"bandwidth": 0.0}, "bandwidth"), ({"bandwidth": 100.0, "delay": -1}, "delay")]
)
def test_bad_settings_are_named(kw: dict[str, float], words: str) -> None:
    with pytest.raises(ValueError, match=words):
        SpeedObserver(A_M, B_M, dt=T, **kw)  # type: ignore[arg-type]


def _exact_run(skip: set[int], *, coast: bool) -> list[float]:
    """The observer on the exact model (no quantum), u a sine, the samples in ``skip`` never
    arriving (the drive holding the latest command over them); its speed errors [rad/s]."""
    phi, gamma = zoh([[0.0, 1.0], [0.0, -A_M]], [[0.0], [B_M]], dt=T)
    obs = SpeedObserver(A_M, B_M, dt=T, bandwidth=500.0)
    x, u, errors, missed = np.zeros(2), 0.0, [], 0
    for k in range(3000):
        if k in skip:
            missed += 1
        else:
            if coast:
                obs.coast(missed)
            missed = 0
            w = obs.update(float(x[0]))
            u = 3.0 + 2.0 * math.sin(2.0 * math.pi * 5.0 * k * T)
            obs.command(u)
            errors.append(w - x[1])
        x = phi @ x + (gamma * u).reshape(2)
    return errors


def test_periods_without_a_sample_are_predicted_through() -> None:
    """A skipped or late sample: ``coast`` predicts over the periods that passed with the held
    command, so the next sample finds the estimate where the shaft is (on the exact model, to
    rounding); without it the next correction takes the two periods' travel as one (a speed
    error of tens of rad/s)."""
    skip = {1500, 2000, 2001, 2002}
    coasted, stepped = _exact_run(skip, coast=True), _exact_run(skip, coast=False)
    assert max(abs(e) for e in coasted[100:]) < 1e-6, max(abs(e) for e in coasted[100:])
    assert max(abs(e) for e in stepped[100:]) > 1.0
    assert _exact_run(set(), coast=True) == _exact_run(set(), coast=False)  # nothing to coast: as before
