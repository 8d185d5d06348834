"""``rig bench sweep``: a study's points per second on 1 and 2 local workers, and what 100 give.

The study: ``points`` points of examples/dc_servo_position.toml, each a 0.2 s emulated run
(500 cycles at 0.4 ms) with its own plant b_m, on a LocalCluster of 1 and then 2 worker
processes (the cluster's start-up is not counted: from the first task's submit to the last
row). Figures:

- points/s at 1 and 2 workers, their ratio and the scaling efficiency (ratio / 2);
- the overhead of a point: median over the points of its seconds in the worker less its
  loop's (set-up, close, the run directory), plus the dispatch (the 1-worker sweep's seconds
  per point less a point's mean seconds in the worker: the scheduler, the transfer, the row);
- 100 workers, estimated from these costs: each worker gives 1 / (a point's seconds in the
  worker + dispatch) points/s, and the client takes ``client_cpu`` seconds of CPU per row (the
  1-worker sweep's process time per point: the table, the progress, the in-process scheduler),
  so at most 1 / client_cpu: the estimate is the smaller of 100 times the one and the other.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rig.bench.micro import Figure

__all__ = ["bench_sweep"]

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _spec(folder: str, points: int) -> Path:
    path = Path(folder) / "bench.toml"
    path.write_text(
        f'[sweep]\nname = "bench"\nbase = "{EXAMPLE}"\noutput = "{folder}"\nmetrics = ["rms_error"]\n'
        '[fixed]\n"run.duration" = 0.2\n'
        '[parameters]\n"emulator.params.b_m" = '
        f'{{ from = 340.0, to = 1360.0, num = {points}, scale = "log" }}\n'
    )
    return path


def _sweep(workers: int, points: int) -> tuple[float, float, list[dict[str, Any]]]:
    """(seconds from submit to the last row, the client's CPU seconds meanwhile, the rows)."""
    from rig.sweep.engine import close_client, open_client, run_sweep
    from rig.sweep.load import load_spec

    with tempfile.TemporaryDirectory() as folder:
        spec = load_spec(_spec(folder, points))
        client, engine = open_client(workers)
        try:
            cpu = time.process_time()
            done = run_sweep(spec, client, engine, every=1.0)
            cpu = time.process_time() - cpu
        finally:
            close_client(client)
    failed = [r for r in done.results.rows.values() if r.get("error")]
    if failed:
        raise RuntimeError(f"rig bench sweep: a point failed: {failed[0]['error']}")
    return done.seconds, cpu, list(done.results.rows.values())


def bench_sweep(*, points: int = 24, progress: Callable[[int, int], None] | None = None) -> list[Figure]:
    """Points/s of a sweep of 0.2 s emulated runs at 1 and 2 workers; overhead; 100 workers.

    Parameters
    ----------
    points : int, optional
        Points of the sweep.
    progress : Callable[[int, int], None] | None, optional
        ``progress(done, total)``.

    Returns
    -------
    list[Figure]
        The figures.
    """
    load = {"name": "load_average_1min", "value": round(os.getloadavg()[0], 2), "unit": "(uptime)"}
    one, cpu, rows = _sweep(1, points)
    if progress is not None:
        progress(1, 2)
    two, _, _ = _sweep(2, points)
    if progress is not None:
        progress(2, 2)
    rate1, rate2 = points / one, points / two
    in_worker = [r["elapsed_s"] for r in rows]
    overhead = [r["elapsed_s"] - r["run_s"] for r in rows]
    dispatch = max(one / points - statistics.mean(in_worker), 0.0)
    per_worker = 1.0 / (statistics.mean(in_worker) + dispatch)
    client = cpu / points
    estimate = min(100 * per_worker, 1.0 / client if client > 0 else float("inf"))
    r = round
    return [
        load,
        {"name": "sweep_points", "value": points, "unit": "points of 0.2 s (500 cycles)"},
        {"name": "sweep_points_per_s_1_worker", "value": r(rate1, 3), "unit": "points/s"},
        {"name": "sweep_points_per_s_2_workers", "value": r(rate2, 3), "unit": "points/s"},
        {"name": "sweep_speedup_2_workers", "value": r(rate2 / rate1, 3), "unit": "x"},
        {
            "name": "sweep_scaling_efficiency_2_workers",
            "value": r(rate2 / rate1 / 2, 3),
            "unit": "(1 = linear)",
        },
        {
            "name": "sweep_point_run_median",
            "value": r(statistics.median(r_["run_s"] for r_ in rows), 4),
            "unit": "s",
        },
        {
            "name": "sweep_point_overhead_median",
            "value": r(statistics.median(overhead) + dispatch, 4),
            "unit": "s",
        },
        {"name": "sweep_point_setup_close_median", "value": r(statistics.median(overhead), 4), "unit": "s"},
        {"name": "sweep_point_dispatch", "value": r(dispatch, 4), "unit": "s"},
        {"name": "sweep_client_cpu_per_point", "value": r(client, 5), "unit": "s"},
        {"name": "sweep_estimate_100_workers", "value": r(estimate, 1), "unit": "points/s"},
        {"name": "load_average_1min", "value": round(os.getloadavg()[0], 2), "unit": "(uptime)"},
    ]
