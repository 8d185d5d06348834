"""Reading back what the recorder wrote: a run directory's configuration and samples."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from drivers.errors import ConfigError
from drivers.files import SAMPLES_LIMIT, read_json, read_text

__all__ = ["RunSamples", "on_period_grid", "read_run", "read_samples"]


def read_samples(run_dir: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """config.json and the samples of a run directory.

    Parameters
    ----------
    run_dir : str | Path
        The run directory.

    Returns
    -------
    tuple[dict[str, Any], dict[str, np.ndarray]]
        (config.json, {column: samples}).

    Raises
    ------
    ConfigError
        Naming what is missing or what is wrong with it (``drivers.files``: regular files, size
        limits, UTF-8, depth).
    """
    d = Path(run_dir)
    if not (d / "config.json").exists() or not (d / "samples.csv").exists():
        raise ConfigError(f"{d}: not a run directory with config.json and samples.csv")
    config = read_json(d / "config.json", what="run configuration")
    if not isinstance(config, dict):
        raise ConfigError(f"{d / 'config.json'}: not a JSON object")
    text = read_text(d / "samples.csv", limit=SAMPLES_LIMIT, what="run's samples")
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        raise ConfigError(f"{d / 'samples.csv'}: empty")
    head = rows[0]
    try:
        data = np.array(rows[1:], dtype=float).reshape(-1, len(head))
    except ValueError as exc:
        raise ConfigError(f"{d / 'samples.csv'}: not a table of numbers: {exc}") from exc
    return config, {name: data[:, i] for i, name in enumerate(head)}


class RunSamples(NamedTuple):
    """A run's command and measurement, one per period from its first sample."""

    command: np.ndarray  #: one per period
    measurement: np.ndarray  #: one per period
    period: float  #: [s]
    filled: int  #: samples of skipped cycles put back (``on_period_grid``)


def on_period_grid(
    t: np.ndarray, u: np.ndarray, y: np.ndarray, period: float, where: str
) -> tuple[np.ndarray, np.ndarray, int]:
    """The rows on the grid of ``period``, a real-time run's skipped cycles put back.

    Skipped cycles (overruns: no row, nothing sent) come back with u as the drive held it (the last
    command sent) and y interpolated linearly.

    Parameters
    ----------
    t : np.ndarray
        [s] the rows' times.
    u, y : np.ndarray
        The rows' command and measurement.
    period : float
        [s] the run's period.
    where : str
        The file, named in the error.

    Returns
    -------
    tuple[np.ndarray, np.ndarray, int]
        (u, y, the samples put back).

    Raises
    ------
    ConfigError
        Naming ``where`` when ``t`` does not increase by whole periods.
    """
    k = np.rint((t - t[0]) / period).astype(np.int64) if len(t) else np.zeros(0, np.int64)
    steps = np.diff(k)
    if len(steps) and steps.min() < 1:
        line = int(np.argmax(steps < 1)) + 3  # the later sample's line in the file (header: line 1)
        raise ConfigError(f"{where}: t does not increase by whole periods of {period:g} s at line {line}")
    n = int(k[-1]) + 1 if len(k) else 0
    if n == len(k):
        return u, y, 0
    grid = np.arange(n)
    held = u[np.searchsorted(k, grid, side="right") - 1]
    return held, np.interp(grid, k, y), n - len(k)


def read_run(run_dir: str | Path) -> RunSamples:
    """The command and measurement of a recorded run on its period's grid (`on_period_grid`).

    Parameters
    ----------
    run_dir : str | Path
        The run directory.

    Returns
    -------
    RunSamples
        Its command, measurement, period and the samples put back.

    Raises
    ------
    ConfigError
        Naming the file: no command or measurement column, no valid period.
    """
    d = Path(run_dir)
    config, columns = read_samples(d)
    try:
        u, theta = columns["command"], columns["measurement"]
    except KeyError as exc:
        raise ConfigError(f"{d / 'samples.csv'}: needs the columns command and measurement") from exc
    run = config.get("run")
    period = config.get("resolved_period") or (run.get("period") if isinstance(run, dict) else None)
    if not period:
        raise ConfigError(f"{d / 'config.json'}: no resolved_period")
    if isinstance(period, bool) or not isinstance(period, (int, float)) or not 0.0 < period < math.inf:
        raise ConfigError(f"{d / 'config.json'}: resolved_period = {period!r}: expected a period > 0 s")
    if "t" not in columns:
        return RunSamples(u, theta, float(period), 0)
    u, theta, filled = on_period_grid(columns["t"], u, theta, float(period), str(d / "samples.csv"))
    return RunSamples(u, theta, float(period), filled)
