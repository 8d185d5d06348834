"""Reading back what the recorder wrote: a run directory's configuration and samples."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import ConfigError
from drivers.files import SAMPLES_LIMIT, read_json, read_text

__all__ = ["read_run", "read_samples"]


def read_samples(run_dir: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(config.json, {column: samples}) of a run directory; ConfigError naming what is missing
    or what is wrong with it (``drivers.files``: regular files, size limits, UTF-8, depth)."""
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


def read_run(run_dir: str | Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(command, measurement, period [s]) of a recorded run."""
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
    return u, theta, float(period)
