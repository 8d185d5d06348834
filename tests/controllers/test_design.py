"""Delta model (6.9) and sliding-vector design (6.16)-(6.19) against the paper's numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.design import acker, design_dtsm, lambda_delta
from controllers.discretize import delta_model, zoh


def test_zoh_matches_closed_form_first_order() -> None:
    a, b, T = -3.0, 2.0, 0.1
    A_d, b_d = zoh([[a]], [b], dt=T)
    assert A_d[0, 0] == pytest.approx(math.exp(a * T), rel=1e-13)
    assert b_d[0, 0] == pytest.approx(b * math.expm1(a * T) / a, rel=1e-13)


def test_delta_model_tends_to_continuous_model() -> None:
    A = np.array([[0.0, 1.0], [0.0, -16.0]])
    A_delta, b_delta = delta_model(A, [0.0, 680.0], dt=1e-7)
    assert np.allclose(A_delta, A, atol=1e-4)
    assert np.allclose(b_delta, [0.0, 680.0], atol=1e-3)


def test_error_space_design_reproduces_7_31_to_every_printed_digit() -> None:
    d = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, -680.0], dt=0.4e-3, lam=-15.0)
    (a11, a12), (a21, a22) = d.A_delta
    assert (round(a11, 4), round(a12, 4), round(a21, 4), round(a22, 4)) == (
        0.0,
        0.9968,
        0.0,
        -15.9489,
    )
    assert round(d.b_delta[0], 5) == -0.13571
    assert round(d.b_delta[1], 6) == -677.828635
    assert [round(c, 4) for c in d.c_delta] == [-0.0221, -0.0015]
    assert [round(k, 4) for k in d.c_delta_A_delta] == [0.0, 0.0015]


def test_sliding_vector_is_normalised_and_places_the_sliding_pole() -> None:
    d = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, -680.0], dt=0.4e-3, lam=-15.0)
    c, A, b = np.array(d.c_delta), np.array(d.A_delta), np.array(d.b_delta)
    assert float(c @ b) == pytest.approx(1.0, abs=1e-12)
    # On g = 0 with the equivalent control (6.14), the motion has the delta pole lambda_delta.
    closed = A - np.outer(b, c @ A)
    eig = sorted(np.linalg.eigvals(closed).real)
    assert eig[0] == pytest.approx(d.lambda_delta, rel=1e-9)
    assert d.lambda_delta == pytest.approx(math.expm1(-15.0 * 0.4e-3) / 0.4e-3, rel=1e-15)


def test_table_v_position_row_with_lambda_minus_25() -> None:
    """Table V: A=[0 1; 0 -500], b=[0; 500], T=1 ms gives k_s=[0, -0.9373], c_s=[0.0627, 0.0025]."""
    d = design_dtsm(A=[[0.0, 1.0], [0.0, -500.0]], b=[0.0, 500.0], dt=1e-3, lam=-25.0)
    assert [round(c, 4) for c in d.c_delta] == [0.0627, 0.0025]
    assert [round(k, 4) for k in d.c_delta_A_delta] == [0.0, -0.9373]


def test_table_v_position_row_does_not_fit_neighbouring_lambdas() -> None:
    for lam in (-24.0, -26.0):
        d = design_dtsm(A=[[0.0, 1.0], [0.0, -500.0]], b=[0.0, 500.0], dt=1e-3, lam=lam)
        assert round(d.c_delta[0], 4) != 0.0627


def test_table_v_q_current_row() -> None:
    """Table V: a_i=-233.8936, b_i=42.8992, T=0.1 ms: c_s=0.0236, k_eq=-5.4521 (printed truncated)."""
    d = design_dtsm(A=[[-233.8936]], b=[42.8992], dt=1e-4, lam=-1.0)
    assert round(d.c_delta[0], 4) == 0.0236
    assert math.trunc(d.c_delta_A_delta[0] * 1e4) / 1e4 == -5.4521
    assert d.c_delta[0] * d.b_delta[0] == pytest.approx(1.0, abs=1e-12)


def test_ackermann_handles_repeated_poles() -> None:
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -2.0, -3.0]])
    b = np.array([0.0, 0.0, 1.0])
    k = acker(A, b, [-2.0, -2.0, -2.0])
    assert np.allclose(np.poly(A - np.outer(b, k)), np.poly([-2.0, -2.0, -2.0]))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": -1e-3}, "dt"),
        ({"dt": math.nan}, "dt"),
        ({"lam": 1.0}, "lambda"),
        ({"b": [0.0, 0.0]}, "not controllable"),
        ({"A": [[-1.0, 0.0], [0.0, -2.0]], "b": [1.0, 0.0]}, "not controllable"),
        ({"A": [[1.0, 2.0, 3.0]]}, "square"),
    ],
)
def test_bad_design_input_names_the_problem(kwargs: dict[str, object], match: str) -> None:
    args: dict[str, object] = {
        "A": [[0.0, 1.0], [0.0, -16.0]],
        "b": [0.0, 680.0],
        "dt": 1e-3,
        "lam": -15.0,
    }
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        design_dtsm(**args)  # type: ignore[arg-type]


def test_lambda_delta_limit() -> None:
    assert lambda_delta(-15.0, dt=1e-9) == pytest.approx(-15.0, rel=1e-6)
