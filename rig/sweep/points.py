"""The points of a study: a grid, random samples or a Latin hypercube, each repeated over seeds.

- grid: every combination of the parameters' values (a range gives ``num`` points), the last
  parameter varying fastest;
- random: ``samples`` independent draws, uniform on each range's scale (log: log-uniform),
  a value list picked from uniformly (numpy's PCG64 seeded with ``seed``);
- lhs: ``samples`` points of a Latin hypercube (scipy.stats.qmc.LatinHypercube, seeded): each
  range and each list is cut into ``samples`` equal strata, each stratum used once.

With ``repeats`` R, each point is run R times with the noise seeds noise_seed .. noise_seed+R-1;
points are numbered in this order from 0, and the number is the point's key in the table.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

from rig.sweep.spec import SweepSpec

__all__ = ["Point", "make_points"]


@dataclass(frozen=True)
class Point:
    """One run of the study: its number, the varied values by name, its noise seed (None: the
    base's own) and which repeat it is."""

    index: int  #: its number
    values: dict[str, Any]  #: the varied values by name
    seed: int | None = None  #: its noise seed (None: the base's)
    repeat: int = 0  #: which repeat it is


def _samples(spec: SweepSpec) -> list[tuple[Any, ...]]:
    params = spec.parameters
    if spec.method == "grid":
        return list(itertools.product(*(p.grid() for p in params)))
    import numpy as np

    n = spec.samples
    if spec.method == "random":
        rng = np.random.default_rng(spec.seed)
        u = rng.random((n, len(params)))
    else:
        from scipy.stats import qmc

        u = qmc.LatinHypercube(d=len(params), seed=spec.seed).random(n)
    rows = []
    for q in u:
        row = []
        for p, x in zip(params, q):
            if p.values:  # a list: the stratum (or draw) picks an element
                row.append(p.values[min(int(x * len(p.values)), len(p.values) - 1)])
            else:
                row.append(p.at(float(x)))
        rows.append(tuple(row))
    return rows


def _plain(value: Any) -> Any:
    """numpy scalars as Python's (a row is pickled to workers and written to Parquet)."""
    return value.item() if hasattr(value, "item") else value


def make_points(spec: SweepSpec) -> list[Point]:
    """Every point of ``spec``, numbered (see the module docstring).

    Parameters
    ----------
    spec : SweepSpec
        The study.

    Returns
    -------
    list[Point]
        The points.
    """
    names = [p.name for p in spec.parameters]
    seeds: list[int | None] = (
        [None]
        if spec.repeats == 1 and spec.noise_seed is None
        else [(spec.noise_seed or 0) + r for r in range(spec.repeats)]
    )
    points: list[Point] = []
    for row in _samples(spec):
        values = {n: _plain(v) for n, v in zip(names, row)}
        for r, seed in enumerate(seeds):
            points.append(Point(len(points), values, seed, r))
    return points
