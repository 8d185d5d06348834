"""``rig reproduce dq-current``: Tables II-III and the decoupling study of the dq-current paper.

Tables II and III: for each strategy and gamma, a q-current step of the
complex-vector controller (32)-(34)/(37) on the plant (29) (``plant=exact``) or
on the stationary-frame converter model (``plant=fine``), at omega_k/omega_s =
``ratio``. Overshoot, rise time (5 % -> 95 %, in samples: first sample at 95 %
minus first sample at 5 %) and settling time (5 % band, in samples: the first
sample after which the response stays inside) come from the simulated response;
gain margin, phase margin and bandwidth/f_s from the open loop R(z) G(z) of the
implemented controller and (29) (``rig.report.margins.loop_margins``).

For s-PWM-middle the loop is gamma (z + beta_1)/(z^2 - z) (38) with the complex
beta_1 = beta_0 e^{-j omega_k T_s/2}; Table III fits beta_1 = 1 (resistance and
frame speed neglected), so each s-PWM-middle row is given twice: ``variant``
"plant" (beta_1 of the plant) and "beta1=1" ((38)-(39) with beta_1 = 1).

Cross-coupling: peak |i_d| per unit q-reference step, for the proposed
controller, the PI that equals it at omega_k = 0 (``pi``) and that PI with
j omega_k L_1 i feed-forward (``pi-decoupled``), at the paper's ratios with the
Table IV parameters and the gamma of the paper's oscillograms.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from controllers.dq_current import (
    PWM_STRATEGIES,
    ComplexVectorCurrentController,
    DqCurrentParams,
    DqPI,
    DqPIParams,
    dead_time_fraction,
    pi_gains_like,
)
from plant_emulator.rl_dq import ExactDqPlant, RLParams, StationaryRLConverter
from rig.report.margins import loop_margins
from rig.report.step_response import overshoot

__all__ = [
    "CROSS_GAMMA",
    "DQ_FIXED",
    "DQ_PARAM_NAMES",
    "PAPER_RATIOS",
    "PRINTED_TABLES",
    "DqStudy",
    "StepRun",
    "cross_coupling",
    "dq_study",
    "step_response",
    "table_rows",
]

TABLE_GAMMAS = {
    "s-pwm-start": (0.25, 0.30, 0.35, 0.40),
    "s-pwm-middle": (0.20, 0.25, 0.30, 0.35),
    "a-pwm-double": (0.25, 0.30, 0.35, 0.40),
}
#: omega_k/omega_s of the measurements, section VIII.
PAPER_RATIOS = {
    "s-pwm-start": (1 / 27, 1 / 51),
    "s-pwm-middle": (1 / 27, 1 / 51),
    "a-pwm-double": (1 / 30, 1 / 54),
}
#: gamma of the oscillograms, Figs. 9(c), 10(c), 11(c).
CROSS_GAMMA = {"s-pwm-start": 0.35, "s-pwm-middle": 0.25, "a-pwm-double": 0.30}
#: Tables II and III as printed: gamma -> (bw/f_s, GM dB, PM deg, OS %, rise, settling).
PRINTED_TABLES: dict[str, dict[float, tuple[float, float, float, float, int, int]]] = {
    "s-pwm-start": {
        0.25: (0.07, 12.0, 68, 0, 6, 8),
        0.30: (0.10, 10.5, 64, 1, 4, 6),
        0.35: (0.13, 9.1, 60, 6, 3, 7),
        0.40: (0.16, 8.0, 55, 12, 2, 8),
    },
    "s-pwm-middle": {
        0.20: (0.11, 14.0, 67, 0, 4, 5),
        0.25: (0.15, 12.1, 62, 4, 3, 3),
        0.30: (0.19, 10.5, 58, 11, 2, 6),
        0.35: (0.22, 9.2, 52, 18, 2, 5),
    },
}
PRINTED_TABLES["a-pwm-double"] = PRINTED_TABLES["s-pwm-start"]
CONTROLLERS = ("proposed", "pi", "pi-decoupled")


@dataclass(frozen=True)
class DqStudy:
    """The study's settings; None means the paper's set (all strategies, its gammas, its ratios).

    Raises
    ------
    ValueError
        If a setting is out of its range.
    """

    L1: float = 6e-3  #: line-filter inductance [H], Table IV
    R1: float = 0.36  #: line-filter resistance [Ohm], Table IV
    f_line: float = 50.0  #: omega_k / 2 pi [Hz], Table IV
    strategy: str | None = None  #: one PWM strategy (None: all)
    gamma: float | None = None  #: one gamma (None: the paper's)
    ratio: float | None = None  #: omega_k / omega_s
    plant: Literal["exact", "fine"] = "exact"  #: (29), or the fine model (StationaryRLConverter)
    steps: int = 80  #: samples of each step response

    def __post_init__(self) -> None:
        if self.strategy is not None:
            dead_time_fraction(self.strategy)  # ValueError naming the known strategies
        for name, lower in (("L1", 0.0), ("R1", None), ("gamma", 0.0)):
            value = getattr(self, name)
            if value is None:
                continue
            ok = math.isfinite(value) and (value >= 0.0 if lower is None else value > lower)
            if not ok:
                raise ValueError(
                    f"{name} must be a finite number {'>= 0' if lower is None else '> 0'}, got {value!r}"
                )
        if self.ratio is not None and not 0.0 < self.ratio < 0.5:
            raise ValueError(f"ratio omega_k/omega_s must be in (0, 1/2) (Nyquist), got {self.ratio!r}")

    def strategies(self) -> tuple[str, ...]:
        """The strategies studied.

        Returns
        -------
        tuple[str, ...]
            Their names.
        """
        return (self.strategy,) if self.strategy else tuple(PWM_STRATEGIES)

    def gammas(self, strategy: str) -> tuple[float, ...]:
        """The gammas studied with ``strategy``.

        Parameters
        ----------
        strategy : str
            A PWM strategy.

        Returns
        -------
        tuple[float, ...]
            The gammas.
        """
        return (self.gamma,) if self.gamma is not None else TABLE_GAMMAS[strategy]

    def ratios(self, strategy: str) -> tuple[float, ...]:
        """The ratios of sampling to line frequency studied with ``strategy``.

        Parameters
        ----------
        strategy : str
            A PWM strategy.

        Returns
        -------
        tuple[float, ...]
            The ratios.
        """
        return (self.ratio,) if self.ratio is not None else PAPER_RATIOS[strategy]


DQ_PARAM_NAMES = ("ratio", "L1", "R1", "gamma", "strategy", "plant")
#: study settings ``--param`` may not set
DQ_FIXED = ("f_line", "steps")


@dataclass
class StepRun:
    """A unit q-reference step: i[k] is the dq current k samples after the step (i[0] = 0)."""

    strategy: str  #: the PWM strategy
    ratio: float  #: of sampling to line frequency
    controller: str  #: which controller
    gamma: float  #: its gamma
    i: np.ndarray = field(repr=False)  #: [A] the dq current after the step

    @property
    def peak_id(self) -> float:
        """Peak |i_d| per unit q step."""
        return float(np.max(np.abs(self.i.real)))


def _timing(study: DqStudy, strategy: str, ratio: float) -> tuple[float, float]:
    """(T_s [s], omega_k [rad/s]) for omega_k/omega_s = ratio."""
    omega_k = 2.0 * math.pi * study.f_line
    return ratio / study.f_line, omega_k


def step_response(
    study: DqStudy, strategy: str, ratio: float, gamma: float, controller: str, *, l1_model: float = 0.0
) -> StepRun:
    """Simulate a unit q-reference step, lock-step controller + plant; the controller is designed
    with the inductance ``l1_model`` [H] (0: the plant's L1; ``rig sweep``'s error in L).

    Parameters
    ----------
    study : DqStudy
        The settings.
    strategy : str
        The PWM strategy.
    ratio : float
        Of sampling to line frequency.
    gamma : float
        The design's gamma.
    controller : str
        Which controller.
    l1_model : float, optional
        [H] the inductance designed with (0: the plant's).

    Returns
    -------
    StepRun
        The run.
    """
    ts, omega_k = _timing(study, strategy, ratio)
    rl = RLParams(r1=study.R1, l1=study.L1, ts=ts, m=dead_time_fraction(strategy))
    plant = ExactDqPlant(rl) if study.plant == "exact" else StationaryRLConverter(rl)
    l1 = l1_model or study.L1
    if controller == "proposed":
        ctl: ComplexVectorCurrentController | DqPI = ComplexVectorCurrentController(
            DqCurrentParams(r1=study.R1, l1=l1, ts=ts, gamma=gamma, strategy=strategy)
        )
    else:
        k_p, k_i = pi_gains_like(study.R1, l1, ts, gamma)
        ctl = DqPI(DqPIParams(k_p=k_p, k_i=k_i, l1=l1, decouple=controller == "pi-decoupled"))
    out = np.zeros(study.steps + 1, dtype=complex)
    i = 0j
    for k in range(1, study.steps + 1):
        i = plant.step(ctl.step(1j, i, omega_k), omega_k)
        out[k] = i
    return StepRun(strategy, ratio, controller, gamma, out)


def _step_metrics(y: np.ndarray) -> tuple[float, float, float]:
    """(overshoot %, rise samples 5 -> 95 %, settling samples into 5 %) of a unit step response.

    y[k] is the response k samples after the step; settling is the first k from
    which y stays within 5 % of 1 (NaN if not settled within the record).
    """
    above5, above95 = np.nonzero(y >= 0.05)[0], np.nonzero(y >= 0.95)[0]
    rise = float(above95[0] - above5[0]) if above5.size and above95.size else math.nan
    outside = np.nonzero(np.abs(y - 1.0) > 0.05)[0]
    settle = float(outside[-1] + 1) if outside.size and outside[-1] < y.size - 1 else math.nan
    return overshoot(y, final=1.0), rise, settle


def _closed_loop_39(gamma: float, beta1: float, steps: int) -> np.ndarray:
    """Unit step response of (39), y[k] k samples after the step:
    y_k = (1 - gamma) y_{k-1} - beta_1 gamma y_{k-2} + gamma (r_{k-1} + beta_1 r_{k-2})."""
    y = np.zeros(steps + 1)
    y[1] = gamma
    for k in range(2, steps + 1):
        y[k] = (1.0 - gamma) * y[k - 1] - beta1 * gamma * y[k - 2] + gamma * (1.0 + beta1)
    return y


def _loop(ctl: ComplexVectorCurrentController, plant: ExactDqPlant, omega_k: float) -> Any:
    """z -> R(z) G(z): the implemented controller (32) times the plant (29)."""
    return lambda z: ctl.transfer(z, omega_k) * plant.transfer(z, omega_k)


def table_rows(study: DqStudy) -> list[dict[str, Any]]:
    """Tables II and III: one row per strategy, gamma and (for s-PWM-middle) variant.

    Parameters
    ----------
    study : DqStudy
        The settings.

    Returns
    -------
    list[dict[str, Any]]
        One row per strategy, gamma and variant.
    """
    rows = []
    for strategy in study.strategies():
        ratio = study.ratios(strategy)[0]
        ts, omega_k = _timing(study, strategy, ratio)
        plant = ExactDqPlant(RLParams(study.R1, study.L1, ts, dead_time_fraction(strategy)))
        for gamma in study.gammas(strategy):
            ctl = ComplexVectorCurrentController(DqCurrentParams(study.R1, study.L1, ts, gamma, strategy))
            run = step_response(study, strategy, ratio, gamma, "proposed")
            variants: list[tuple[str, np.ndarray, Any]] = [
                ("plant", run.i.imag, _loop(ctl, plant, omega_k)),
            ]
            if strategy == "s-pwm-middle":
                variants.append(
                    (
                        "beta1=1",
                        _closed_loop_39(gamma, 1.0, study.steps),
                        lambda z, g=gamma: g * (z + 1.0) / (z * z - z),
                    )
                )
            for variant, y, loop in variants:
                os_, rise, settle = _step_metrics(y)
                m = loop_margins(loop)
                rows.append(
                    {
                        "strategy": strategy,
                        "gamma": gamma,
                        "overshoot_percent": os_,
                        "rise_samples": rise,
                        "settling_samples": settle,
                        "gain_margin_db": m.gain_margin_db,
                        "phase_margin_deg": m.phase_margin_deg,
                        "bandwidth_ratio": m.bandwidth_ratio,
                        "ratio": ratio,
                        "variant": variant,
                        "plant": study.plant,
                    }
                )
    return rows


def cross_coupling(study: DqStudy) -> list[StepRun]:
    """q-step runs of the three controllers at each strategy's ratios.

    Parameters
    ----------
    study : DqStudy
        The settings.

    Returns
    -------
    list[StepRun]
        The runs.
    """
    runs = []
    for strategy in study.strategies():
        gamma = study.gamma if study.gamma is not None else CROSS_GAMMA[strategy]
        for ratio in study.ratios(strategy):
            for controller in CONTROLLERS:
                runs.append(step_response(study, strategy, ratio, gamma, controller))
    return runs


def dq_study(
    study: DqStudy, *, progress: Callable[[int, int], None] | None = None
) -> tuple[list[dict[str, Any]], list[StepRun]]:
    """Both parts of the reproduction: (table rows, cross-coupling runs); ``progress(done, 2)``
    after each.

    Parameters
    ----------
    study : DqStudy
        The settings.
    progress : Callable[[int, int], None] | None, optional
        ``progress(done, 2)``.

    Returns
    -------
    tuple[list[dict[str, Any]], list[StepRun]]
        (table rows, cross-coupling runs).
    """
    rows = table_rows(study)
    if progress is not None:
        progress(1, 2)
    runs = cross_coupling(study)
    if progress is not None:
        progress(2, 2)
    return rows, runs
