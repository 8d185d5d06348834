"""``rig reproduce dismc``: section 4 of the DISMC paper, eqs. (47)-(57) and Table 1.

The plant (47) is simulated exactly as printed (already discrete, Ts = 0.02 s),
with d(k) = B * amplitude * sin(k). The printed H of (50) is used for the
reproduction (``H = "printed"``); it does not satisfy (3), whose solution is
H = [-1.0011 -0.1102] (``--param H=solved``). Metrics follow ``rig.report.metrics``:
rise time 5 % -> 95 % of the error transition, settling into 1 % of |e(0)|,
u_min and u_max over the run (u_max is u(0)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from controllers.dismc import DISMC, DISMCParams, dismc_lqr_gain
from controllers.model_following import solve_model_following
from rig.report.step_response import rise_time, settling_time

__all__ = ["ALIASES", "FIXED", "PARAM_NAMES", "DismcExample", "DismcRun", "dismc_laws", "run_dismc"]

PRINTED_H = (-1.0011, 0.1102)  #: H of (50) as printed
K_LMI = (-153.6018, -97.1424)  #: K of (55), from the LMI (28)-(29)


@dataclass(frozen=True)
class DismcExample:
    """Section 4's example; field names are the paper's symbols (``--param``).

    Raises
    ------
    ValueError
        If a field is out of its range.
    """

    A: tuple[tuple[float, ...], ...] = ((0.9802, 0.04), (0.0, 1.0202))  #: (47)
    B: tuple[float, ...] = (0.0004, 0.0202)  #: (47)
    C: tuple[float, ...] = (1.0, 0.0)  #: (47)
    A_m: tuple[tuple[float, ...], ...] = ((0.9998, 0.02), (-0.02, 0.9958))  #: (48)
    C_m: tuple[float, ...] = (1.0, 0.0)  #: (48)
    x0: tuple[float, ...] = (-1.0, 0.0)  #: (49)
    xm0: tuple[float, ...] = (0.0, 1.0)  #: (49)
    S: tuple[float, ...] = (3.0, 1.0)  #: (51)
    phi: float = 0.9  #: (52)
    eta: float = 0.5  #: (52)
    varphi: float = 0.5  #: (52)
    beta: float = 0.9  #: (53)
    mu: float = 1.13  #: (53)
    Q: tuple[tuple[float, ...], ...] = ((1.0, 0.0), (0.0, 1.0))  #: (56)
    R: float = 1.0  #: (56)
    Ts: float = 0.02  #: sampling period [s]
    amplitude: float = 0.1  #: disturbance amplitude of d(k) = B amplitude sin(k)
    H: Literal["printed", "solved"] = "printed"  #: (50) as printed, or solved from (3)
    steps: int = 300  #: samples simulated (6 s)
    #: |u| the actuator delivers at most (the paper's example has no bound: inf); the controllers
    #: do not know it, so their integral winds up where it acts (``rig sweep``'s anti-windup study)
    u_bound: float = math.inf

    def __post_init__(self) -> None:
        for name in ("phi", "eta", "varphi", "beta", "mu", "R", "Ts", "amplitude"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be a finite number, got {getattr(self, name)!r}")
        if not self.Ts > 0.0:
            raise ValueError(f"Ts must be a sampling period > 0 s, got {self.Ts!r}")
        if not self.u_bound > 0.0:
            raise ValueError(f"u_bound must be > 0 (inf: none), got {self.u_bound!r}")
        for name in ("S", "x0", "xm0"):
            if len(getattr(self, name)) != 2 or not all(map(math.isfinite, getattr(self, name))):
                raise ValueError(f"{name} needs 2 finite numbers, got {getattr(self, name)!r}")
        if [len(row) for row in self.Q] != [2, 2] or not all(map(math.isfinite, sum(self.Q, ()))):
            raise ValueError(f"Q needs 4 finite numbers (2x2, row-major as 1,0;0,1), got {self.Q!r}")


@dataclass
class DismcRun:
    """One controller's run: signals and Table 1 metrics."""

    controller: str  #: Table 1's name
    u: np.ndarray  #: the command
    e: np.ndarray  #: the tracking error
    sigma: np.ndarray  #: the sliding function
    metrics: dict[str, float] = field(default_factory=dict)  #: Table 1's metrics


#: parameters of the example that ``--param`` may set (the others are the plant of (47)-(48))
FIXED = ("A", "B", "C", "A_m", "C_m", "steps", "u_bound")  # u_bound: rig sweep's, not the paper's
PARAM_NAMES = ("phi", "eta", "varphi", "beta", "mu", "R", "Ts", "amplitude", "S", "x0", "xm0", "Q", "H")
ALIASES = {"disturbance_amplitude": "amplitude"}


def dismc_laws(example: DismcExample | None = None) -> dict[str, DISMCParams]:
    """The four controllers of Table 1 for ``example``, by Table 1's names.

    Parameters
    ----------
    example : DismcExample | None, optional
        Section 4's example (None: the paper's).

    Returns
    -------
    dict[str, DISMCParams]
        Table 1's name -> the law's parameters.
    """
    ex = example or DismcExample()
    G, H_solved = solve_model_following(A=ex.A, B=ex.B, C=ex.C, A_m=ex.A_m, C_m=ex.C_m)
    H = PRINTED_H if ex.H == "printed" else tuple(H_solved)
    K_lqr = dismc_lqr_gain(A=ex.A, B=ex.B, S=ex.S, Q=ex.Q, R=ex.R)

    def law(variant: str, K: tuple[float, ...] | np.ndarray = ()) -> DISMCParams:
        return DISMCParams.build(
            A=ex.A,
            B=ex.B,
            A_m=ex.A_m,
            G=G,
            H=H,
            S=ex.S,
            K=K,
            phi=ex.phi,
            eta=ex.eta,
            varphi=ex.varphi,
            beta=ex.beta,
            mu=ex.mu,
            variant=variant,
        )

    return {
        "DSMC": law("dsmc"),
        "DISMC-LMI": law("dismc", K_LMI),
        "DISMC-LQR": law("dismc", K_lqr),
        "DISMC-AW-LQR": law("dismc-aw", K_lqr),
    }


def run_dismc(example: DismcExample | None = None, controllers: tuple[str, ...] = ()) -> list[DismcRun]:
    """Simulate DSMC, DISMC-LMI, DISMC-LQR and DISMC-AW-LQR (or those of ``controllers``, by
    Table 1's names) on (47)-(53); u is the controllers' command, the plant takes it within
    +-``u_bound``.

    Parameters
    ----------
    example : DismcExample | None, optional
        Section 4's example (None: the paper's).
    controllers : tuple[str, ...], optional
        Table 1's names (): all four.

    Returns
    -------
    list[DismcRun]
        One run each.
    """
    ex = example or DismcExample()
    laws = dismc_laws(ex)
    A, B, C, Am, Cm = (np.array(v) for v in (ex.A, ex.B, ex.C, ex.A_m, ex.C_m))
    runs = []
    for name, params in laws.items():
        if controllers and name not in controllers:
            continue
        ctl = DISMC(params)
        x, xm = np.array(ex.x0, dtype=float), np.array(ex.xm0, dtype=float)
        u, e, s = (np.empty(ex.steps) for _ in range(3))
        for k in range(ex.steps):
            u[k] = ctl.step(tuple(x), tuple(xm))
            e[k] = C @ x - Cm @ xm
            s[k] = ctl.sigma
            x = A @ x + B * (min(max(u[k], -ex.u_bound), ex.u_bound) + ex.amplitude * math.sin(k))
            xm = Am @ xm
        run = DismcRun(name, u, e, s)
        run.metrics = {
            "rise_time_s": rise_time(e, dt=ex.Ts),
            "settling_time_s": settling_time(e, dt=ex.Ts, band=0.01),
            "u_min": float(u.min()),
            "u_max": float(u.max()),
        }
        runs.append(run)
    return runs
