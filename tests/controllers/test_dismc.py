"""Model following (3), DSMC (12)-(13), DISMC (23)/(34), DISMC-AW (36)/(45), LQR (31)-(32), LMI (28)."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.dismc import DISMC, DISMCParams, dismc_lqr_gain, lmi_28_holds
from controllers.model_following import solve_model_following

A = ((0.9802, 0.04), (0.0, 1.0202))
B = (0.0004, 0.0202)
A_M = ((0.9998, 0.02), (-0.02, 0.9958))


def test_model_following_solves_3_and_flags_the_printed_h() -> None:
    G, H = solve_model_following(A=A, B=B, C=(1.0, 0.0), A_m=A_M, C_m=(1.0, 0.0))
    assert np.round(G, 4).tolist() == [[1.0, 0.0], [0.5, 0.5011]]
    assert np.round(H, 4).tolist() == [-1.0011, -0.1102]
    Am, Bv = np.array(A_M), np.array(B)
    assert np.allclose(np.array(A) @ G + np.outer(Bv, H), G @ Am, atol=1e-12)
    printed = np.array([-1.0011, 0.1102])
    assert not np.allclose(np.array(A) @ G + np.outer(Bv, printed), G @ Am, atol=1e-3)


def test_model_following_for_other_sizes() -> None:
    G, H = solve_model_following(A=[[0.5]], B=[1.0], C=[1.0], A_m=[[1.0, 0.1], [0.0, 1.0]], C_m=[1.0, 0.0])
    assert G.shape == (1, 2) and H.shape == (2,)


def test_model_following_without_solution_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match=r"\(3\) has no solution"):
        solve_model_following(A=[[1.0, 0.0], [0.0, 1.0]], B=[0.0, 0.0], C=[1.0, 0.0], A_m=[[0.5]], C_m=[1.0])


def test_lqr_gain_equals_57_to_four_digits() -> None:
    K = dismc_lqr_gain(A=A, B=B, S=(3.0, 1.0), Q=np.eye(2), R=1.0)
    assert np.round(K, 4).tolist() == [-202.7857, -77.4525]


def test_printed_lmi_solution_54_satisfies_28_and_gives_55() -> None:
    X = np.array([[0.9271, -0.2371], [-0.2371, 1.0729]])
    W = np.array([-119.3733, -67.8097])
    assert lmi_28_holds(A=A, B=B, S=(3.0, 1.0), X=X, W=W)
    K = W @ np.linalg.inv(X)
    # X, W are printed to 4 decimals: W X^-1 agrees with (55) to 1e-4 relative
    assert K == pytest.approx([-153.6018, -97.1424], rel=1e-4)
    assert not lmi_28_holds(A=A, B=B, S=(3.0, 1.0), X=X, W=np.zeros(2))


def _params(**kw: object) -> DISMCParams:
    G, H = solve_model_following(A=A, B=B, C=(1.0, 0.0), A_m=A_M, C_m=(1.0, 0.0))
    base: dict[str, object] = dict(
        A=A, B=B, A_m=A_M, G=G, H=H, S=(3.0, 1.0), phi=0.9, eta=0.5, varphi=0.5, K=(-202.7857, -77.4525)
    )
    base.update(kw)
    return DISMCParams.build(**base)  # type: ignore[arg-type]


def test_dismc_sigma_follows_the_reaching_law_17_without_disturbance() -> None:
    """Without disturbance sigma(k+1) = phi sigma(k) - eta sat(sigma(k)/varphi) + S(d - d_hat)."""
    ctl = DISMC(_params(variant="dismc"))
    x, xm = np.array([-1.0, 0.0]), np.array([0.0, 1.0])
    sig = []
    for _ in range(40):
        u = ctl.step(tuple(x), tuple(xm))
        sig.append(ctl.sigma)
        x = np.array(A) @ x + np.array(B) * u
        xm = np.array(A_M) @ xm
    assert sig[0] == pytest.approx(0.0, abs=1e-12)  # no reaching phase (23a)
    assert max(abs(s) for s in sig) < 1e-9


@pytest.mark.parametrize(
    ("field", "value"), [("phi", 1.0), ("eta", 0.0), ("varphi", -1.0), ("variant", "pid"), ("K", ())]
)
def test_bad_dismc_params(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=r"DISMC|variant|K"):
        _params(**{"variant": "dismc", field: value})


def test_reset_restores_initial_state() -> None:
    ctl = DISMC(_params(variant="dismc-aw"))
    first = [ctl.step((-1.0, 0.0), (0.0, 1.0)), ctl.step((-0.9, 0.1), (0.02, 0.99))]
    ctl.reset()
    assert [ctl.step((-1.0, 0.0), (0.0, 1.0)), ctl.step((-0.9, 0.1), (0.02, 0.99))] == first
