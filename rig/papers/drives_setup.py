"""What the drives paper's reproduction (``rig reproduce drives``) is made of: its parameters
(``DrivesStudy``, what ``--param`` may change), one run's signals for the plots (``Signals``), and
a run over the emulated bus (``bus_run``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rig.host.rundir import read_samples
from rig.host.session import run_config

__all__ = ["DRIVES_FIXED", "DRIVES_PARAM_NAMES", "EXACT", "DrivesStudy", "Signals", "bus_run"]

#: the pure simulations' rows: exact measurements (threshold 0), nothing stops them
EXACT: dict[str, Any] = {"chattering_threshold": 0.0, "safe_stop_reason": None}


@dataclass(frozen=True)
class DrivesStudy:
    """What ``--param`` may change: horizons [s] (shorter ones for quick runs), the sub-steps of
    the speed loop's disturbance, the load T [N m] of section VII.D, and whether to run over the bus.

    Raises
    ------
    ValueError
        If a horizon is not in (0, 60] s, the sub-steps not 1..1000, the load beyond +-10 N m or
        servo_settle not in [0, servo_t_end).
    """

    speed_t_end: float = 5.0  #: Figs. 9-10 horizon; the amplitude is taken over 2.5 s .. this
    substeps: int = 20  #: exact plant sub-steps per sample for f(t) in the speed loop
    servo_t_end: float = 3.0  #: section VII.B horizon (move 0-1 s, load step at 1.5 s)
    servo_settle: float = 2.5  #: start of the servo's steady-state window [s]
    im_t_end: float = 10.0  #: sections VII.C/D horizon (load 2-4 s, sine from 8 s)
    load: float = 5.0  #: T of the load profile [N m]
    bus: bool = True  #: also run over the emulated bus

    def __post_init__(self) -> None:
        for name in ("speed_t_end", "servo_t_end", "im_t_end"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 < value <= 60.0):
                raise ValueError(f"{name} must be in (0, 60] s, got {value!r}")
        if not 1 <= self.substeps <= 1000:
            raise ValueError(f"substeps must be in 1..1000, got {self.substeps!r}")
        if not (math.isfinite(self.load) and abs(self.load) <= 10.0):
            raise ValueError(f"load must be within +-10 N m, got {self.load!r}")
        if not (math.isfinite(self.servo_settle) and 0.0 <= self.servo_settle < self.servo_t_end):
            raise ValueError(f"servo_settle must be in [0, servo_t_end), got {self.servo_settle!r}")


DRIVES_PARAM_NAMES = tuple(f for f in DrivesStudy.__dataclass_fields__)
DRIVES_FIXED: dict[str, str] = {}


@dataclass
class Signals:
    """One run's signals for the plots: time [s] and named arrays (SI)."""

    name: str  #: the run's
    t: np.ndarray  #: [s] the time
    series: dict[str, np.ndarray] = field(default_factory=dict)  #: name -> array (SI)


def bus_run(cfg: Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """``cfg`` run lock-step on the emulated bus: its summary and its recorded columns by name.

    Parameters
    ----------
    cfg : Any
        The configuration.

    Returns
    -------
    tuple[dict[str, Any], dict[str, np.ndarray]]
        (summary, column -> array).
    """
    summary = run_config(cfg, emulate=True)
    _, columns = read_samples(summary["run_dir"])
    return summary, columns
