"""Reading back what the recorder wrote: a run directory's configuration and samples."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import ConfigError

__all__ = ["read_run", "read_samples"]


def read_samples(run_dir: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(config.json, {column: samples}) of a run directory; ConfigError naming what is missing."""
    d = Path(run_dir)
    try:
        config = json.loads((d / "config.json").read_text())
        with (d / "samples.csv").open() as f:
            rows = list(csv.reader(f))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{d}: not a run directory with config.json and samples.csv: {exc}") from exc
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
    period = config.get("resolved_period") or config.get("run", {}).get("period")
    if not period:
        raise ConfigError(f"{d / 'config.json'}: no resolved_period")
    return u, theta, float(period)
