"""The papers' pure simulations a sweep can take as its base (``[sweep] scenario = NAME``).

Each is a function of one point's parameters (a dataclass, typed and checked like every
``--param``) to its metrics, on the code of ``rig reproduce``:

- ``dismc``: section 4 of the DISMC paper, (47)-(53), one controller of Table 1 (``controller``)
  with the actuator's bound ``u_bound`` (the paper has none; ``rig.papers.dismc``). Metrics:
  rise and settling time of the tracking error (as Table 1), its rms and largest value, and the
  command's extremes.
- ``dq-current``: a unit q-reference step of the dq-current paper (Table IV parameters), the
  complex-vector controller (32)-(34)/(37) (``proposed``) or the PI (``pi``, ``pi-decoupled``)
  designed with an inductance off by ``L_error`` (relative: L_model = L1 (1 + L_error)). Metrics:
  the cross-coupling peak |i_d| per unit q step, and the i_q step's overshoot, rise and settling.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

__all__ = ["SCENARIOS", "Scenario"]


@dataclass(frozen=True)
class DismcPoint:
    """A point of the ``dismc`` scenario: a controller of Table 1 and the example's parameters
    (``rig.papers.dismc.DismcExample``, by the paper's symbols)."""

    controller: Literal["DSMC", "DISMC-LMI", "DISMC-LQR", "DISMC-AW-LQR"] = "DISMC-AW-LQR"
    u_bound: float = math.inf  #: the actuator's |u| at most [-]
    amplitude: float = 0.1  #: d(k) = B amplitude sin(k)
    phi: float = 0.9
    eta: float = 0.5
    varphi: float = 0.5
    beta: float = 0.9
    mu: float = 1.13
    R: float = 1.0
    Ts: float = 0.02  #: [s]
    H: Literal["printed", "solved"] = "printed"
    steps: int = 300

    def __post_init__(self) -> None:
        self.example()  # the example's own checks (ValueError), when the spec is loaded

    def example(self) -> Any:
        from rig.papers.dismc import DismcExample

        return DismcExample(**{k: v for k, v in dataclasses.asdict(self).items() if k != "controller"})


@dataclass(frozen=True)
class DqPoint:
    """A point of the ``dq-current`` scenario (``rig.papers.dq_current``)."""

    controller: Literal["proposed", "pi", "pi-decoupled"] = "proposed"
    L_error: float = 0.0  #: the controller's L1 is L1 (1 + L_error) [-]
    strategy: Literal["s-pwm-start", "s-pwm-middle", "a-pwm-double"] = "s-pwm-start"
    ratio: float = 1.0 / 27.0  #: omega_k / omega_s
    gamma: float = 0.0  #: 0: the paper's oscillograms' (rig.papers.dq_current.CROSS_GAMMA)
    L1: float = 6e-3  #: the plant's [H]
    R1: float = 0.36  #: [Ohm]
    plant: Literal["exact", "fine"] = "exact"

    def __post_init__(self) -> None:
        if not self.L_error > -1.0:
            raise ValueError(f"L_error must be > -1 (the model's L1 > 0), got {self.L_error!r}")
        self.study()  # the study's own checks (ValueError), when the spec is loaded

    def study(self) -> Any:
        from rig.papers.dq_current import DqStudy

        return DqStudy(L1=self.L1, R1=self.R1, strategy=self.strategy, ratio=self.ratio, plant=self.plant)


def _dismc(p: DismcPoint) -> dict[str, Any]:
    import numpy as np

    from rig.papers.dismc import run_dismc

    (run,) = run_dismc(p.example(), controllers=(p.controller,))
    return {
        **run.metrics,
        "rms_error": float(np.sqrt(np.mean(run.e**2))),
        "max_error": float(np.max(np.abs(run.e))),
    }


def _dq(p: DqPoint) -> dict[str, Any]:
    from rig.papers.dq_current import CROSS_GAMMA, _step_metrics, step_response

    study = p.study()
    gamma = p.gamma or CROSS_GAMMA[p.strategy]
    run = step_response(study, p.strategy, p.ratio, gamma, p.controller, l1_model=p.L1 * (1.0 + p.L_error))
    overshoot, rise, settle = _step_metrics(run.i.imag)
    return {
        "peak_id": run.peak_id,
        "overshoot_percent": overshoot,
        "rise_samples": rise,
        "settling_samples": settle,
    }


@dataclass(frozen=True)
class Scenario:
    """A pure simulation: ``schema`` (its parameters), ``run(point) -> metrics``, the ``metrics``
    it gives and their ``units``, and whether it takes a ``seed`` (noise)."""

    schema: type  #: its parameters' dataclass
    run: Callable[[Any], dict[str, Any]]  #: point -> metrics
    metrics: tuple[str, ...]  #: the metrics it gives
    units: dict[str, str]  #: metric -> unit
    seeded: bool = False  #: it takes a noise seed


SCENARIOS: dict[str, Scenario] = {
    "dismc": Scenario(
        DismcPoint,
        _dismc,
        ("rise_time_s", "settling_time_s", "rms_error", "max_error", "u_min", "u_max"),
        {"rms_error": "-", "max_error": "-"},  # section 4's example is dimensionless
    ),
    "dq-current": Scenario(
        DqPoint,
        _dq,
        ("peak_id", "overshoot_percent", "rise_samples", "settling_samples"),
        {"peak_id": "per unit of the q step"},
    ),
}
