"""Time profiles written as text (``drivers.profiles``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers.profiles import parse_profile
from plant_emulator.parameters import load_torque

T = np.linspace(-1.0, 12.0, 2601)


def h(t: float) -> float:
    """The unit step."""
    return 1.0 if t >= 0.0 else 0.0


@pytest.mark.parametrize(
    "text,expected",
    [
        ("none", lambda t: 0.0),
        ("const:2.5", lambda t: 2.5),
        ("const:-3", lambda t: -3.0),
        ("step:2:0.6", lambda t: 2.0 * h(t - 0.6)),
        ("step:-1:0", lambda t: -h(t)),
        ("sine:5:1", lambda t: 5.0 * math.sin(2.0 * math.pi * t)),
        ("pulse:5:2:4", lambda t: 5.0 * (h(t - 2.0) - h(t - 4.0))),
        ("sine:5:2:8", lambda t: 5.0 * h(t - 8.0) * math.sin(4.0 * math.pi * t)),
        ("const:1e+3", lambda t: 1000.0),
        ("const:2.5E-1 + const:1", lambda t: 1.25),
        ("none + step:1:1", lambda t: h(t - 1.0)),
    ],
)
def test_each_kind_and_the_old_forms(text: str, expected: object) -> None:
    f = parse_profile(text)
    for t in T:
        assert f(float(t)) == pytest.approx(expected(float(t)), abs=1e-12), (text, t)  # type: ignore[operator]


def test_the_drives_paper_load_of_section_vii_d() -> None:
    """T_L = 5 [h(t-2) - h(t-4) + h(t-8) sin(4 pi t)]."""
    f = parse_profile("pulse:5:2:4 + sine:5:2:8")
    for t in map(float, T):
        paper = 5.0 * (h(t - 2.0) - h(t - 4.0) + h(t - 8.0) * math.sin(4.0 * math.pi * t))
        assert f(t) == pytest.approx(paper, abs=1e-12), t
    assert f(1.999) == 0.0 and f(2.0) == 5.0 and f(3.999) == 5.0 and f(4.0) == 0.0 and f(7.999) == 0.0


def test_edges_are_closed_on_the_left() -> None:
    assert parse_profile("step:1:0.5")(0.5) == 1.0
    assert parse_profile("pulse:1:0.5:0.7")(0.7) == 0.0
    assert parse_profile("sine:1:0.25:1")(0.999) == 0.0
    assert parse_profile("sine:1:0.25:1")(1.0) == pytest.approx(1.0)  # the phase of absolute t


@pytest.mark.parametrize(
    "text,term,reason",
    [
        ("ramp:1:2", "ramp:1:2", "unknown kind 'ramp'"),
        ("const:1 + step:1", "step:1", "step takes 2 numbers, got 1"),
        ("sine:1", "sine:1", "sine takes 2 or 3 numbers, got 1"),
        ("none:1", "none:1", "none takes 0 numbers"),
        ("const:x", "const:x", "arguments must be numbers"),
        ("const:inf", "const:inf", "finite"),
        ("const:1 +", "", "empty term"),
        ("", "", "empty term"),
        ("pulse:1:4:2", "pulse:1:4:2", "t1 > t0"),
    ],
)
def test_errors_name_the_term_and_the_text(text: str, term: str, reason: str) -> None:
    with pytest.raises(ValueError) as exc:
        parse_profile(text)
    message = str(exc.value)
    assert f"profile {text!r}" in message and f"term {term!r}" in message and reason in message


def test_the_presets_load_parameter_uses_it() -> None:
    assert load_torque("none") is None
    f = load_torque("pulse:5:2:4 + sine:5:2:8")
    assert f is not None and f(3.0) == 5.0
    with pytest.raises(ValueError, match=r"profile 'pulse:5:4:2': .* t1 > t0"):
        load_torque("pulse:5:4:2")
