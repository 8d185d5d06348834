"""The identification experiment through the drive driver, and reading it back from a run directory.

The excitation is replayed by the host loop in voltage mode (the u of (3.5)),
so it runs with the configured limits, the TPDO watchdog and the recorder:
any limit ends it through the safe-stop path and keeps what was recorded.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import ConfigError, SafetyStop
from rig.config import RigConfig
from rig.identify import IdentResult, estimate
from rig.loop import Feedback
from rig.run import prepare

__all__ = ["experiment_config", "identify_from_log", "read_run", "run_experiment", "terminal_progress"]


def experiment_config(
    cfg: RigConfig, *, preset: str | None = None, params: dict[str, str] | None = None
) -> RigConfig:
    """``cfg`` made into an identification run: name ``identify``, synchronous RPDO (the delay is
    estimated), no position window, a wide speed limit; ``preset``/``params`` replace the emulator's."""
    return dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, name="identify"),
        emulator=dataclasses.replace(
            cfg.emulator,
            preset=preset or cfg.emulator.preset,
            params=cfg.emulator.params if params is None else params,
        ),
        drive=dataclasses.replace(cfg.drive, sync_rpdo=True),
        limits=dataclasses.replace(cfg.limits, position_min=-math.inf, position_max=math.inf, speed=1000.0),
    )


def run_experiment(
    cfg: RigConfig,
    u: np.ndarray,
    *,
    emulate: bool,
    progress: Callable[[float], None] | None = None,
) -> dict[str, Any]:
    """Replay ``u`` (one value per period) on the drive in voltage mode; returns the run summary."""
    cfg = dataclasses.replace(
        cfg,
        drive=dataclasses.replace(cfg.drive, mode="voltage"),
        controller=dataclasses.replace(cfg.controller, kind="position-servo", params={}),
    )
    session = prepare(cfg, emulate=emulate, duration=len(u) * (cfg.run.period or 1.0))
    loop = session.loop
    period = loop.period
    loop.cycles = len(u)
    step = max(1, len(u) // 20)
    values = [float(v) for v in u]

    def replay(t: float, fb: Feedback) -> tuple[float, float, float, Sequence[float]]:
        k = round(t / period)
        if progress is not None and k % step == 0:
            progress(k / len(values))
        if fb[1] < 0.0 and k > len(values) // 10:
            raise SafetyStop(f"speed {fb[1]:.3g} rad/s changed sign: raise u0 above the friction")
        return values[k], values[k], fb[0], (0.0, 0.0)

    loop.law = replay
    try:
        summary = loop.run()
    finally:
        session.close()
    summary["period"] = period
    return summary


def identify_from_log(run_dir: str | Path, *, max_delay: int = 5) -> IdentResult:
    """Estimate from a recorded run: ``samples.csv`` (command, measurement) and its period."""
    u, theta, period = read_run(run_dir)
    return estimate(u, theta, period, max_delay=max_delay)


def read_run(run_dir: str | Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(command, measurement, period [s]) of a recorded run."""
    d = Path(run_dir)
    try:
        config = json.loads((d / "config.json").read_text())
        with (d / "samples.csv").open() as f:
            rows = list(csv.reader(f))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{d}: not a run directory with config.json and samples.csv: {exc}") from exc
    head = rows[0]
    try:
        data = np.array(rows[1:], dtype=float).reshape(-1, len(head))
        u = data[:, head.index("command")]
        theta = data[:, head.index("measurement")]
    except ValueError as exc:
        raise ConfigError(f"{d / 'samples.csv'}: needs the columns command and measurement: {exc}") from exc
    period = config.get("resolved_period") or config.get("run", {}).get("period")
    if not period:
        raise ConfigError(f"{d / 'config.json'}: no resolved_period")
    return u, theta, float(period)


def terminal_progress(fraction: float) -> None:
    """A progress line on stderr when it is a terminal."""
    if sys.stderr.isatty():
        sys.stderr.write(f"\ridentify: experiment {100 * fraction:5.1f} %")
        sys.stderr.flush()
