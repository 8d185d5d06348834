"""``rig bench startup`` and ``rig bench memory``: what every command pays before and after its work.

- startup: the wall time and the CPU time (user + system) of ``rig --version`` and of a 0.1 s
  emulated ``rig run`` of examples/dc_servo_position.toml (its plot included), each a fresh
  process, the median and range of ``repeats`` runs (on a loaded machine the wall time waits
  for a core, the CPU time much less);
- memory: the peak resident memory (``ru_maxrss`` of the child, ``os.wait4``) of that run at
  25,000 and at 250,000 cycles (10 s and 100 s of run time at its 0.4 ms), the plot and
  samples.mat included: the same figure at both lengths shows a run's memory does not grow
  with its length.

Each prints the machine's load average beside its figures: the machine here is shared.
"""

from __future__ import annotations

import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

from rig.bench.micro import Figure

__all__ = ["bench_memory", "bench_startup"]

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
PERIOD = 0.4e-3  #: [s] the example's (the dc-servo preset's)


def _rig(*args: str) -> list[str]:
    return [sys.executable, "-m", "rig.cli", *args]


def _child(cmd: list[str], cwd: str) -> tuple[float, float, float]:
    """(wall [s], CPU user + system [s], peak resident memory [MB]) of ``cmd`` run to its end."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}")
    return time.perf_counter() - t0, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0  # KiB


def _load() -> Figure:
    return {"name": "load_average_1min", "value": round(os.getloadavg()[0], 2), "unit": "(uptime)"}


def _spread(name: str, values: list[float], unit: str) -> list[Figure]:
    return [
        {"name": f"{name}_median", "value": round(statistics.median(values), 3), "unit": unit},
        {"name": f"{name}_min", "value": round(min(values), 3), "unit": unit},
        {"name": f"{name}_max", "value": round(max(values), 3), "unit": unit},
    ]


def bench_startup(*, repeats: int = 7) -> list[Figure]:
    """Wall and CPU seconds of ``rig --version`` and of a 0.1 s emulated ``rig run`` (fresh
    processes): the wall time waits for a core on a loaded machine, the CPU time does not.

    Parameters
    ----------
    repeats : int, optional
        Fresh processes of each.

    Returns
    -------
    list[Figure]
        The figures (median and range of each).
    """
    figures = [_load()]
    run = _rig("run", "--config", str(EXAMPLE), "--emulate", "--duration", "0.1")
    with tempfile.TemporaryDirectory() as cwd:
        for name, cmd in (("rig_version", _rig("--version")), ("rig_run_0.1s_emulated", run)):
            measured = [_child(cmd, cwd) for _ in range(repeats)]
            figures += _spread(f"{name}_wall", [m[0] for m in measured], "s")
            figures += _spread(f"{name}_cpu", [m[1] for m in measured], "s")
    return [*figures, _load()]


def bench_memory(
    *, cycles: tuple[int, ...] = (25_000, 250_000), progress: Callable[[int, int], None] | None = None
) -> list[Figure]:
    """Peak resident memory of an emulated ``rig run`` of ``cycles`` cycles (a fresh process).

    Parameters
    ----------
    cycles : tuple[int, ...], optional
        The runs' lengths [cycles].
    progress : Callable[[int, int], None] | None, optional
        ``progress(done, total)`` after each run.

    Returns
    -------
    list[Figure]
        The figures, one a run.
    """
    figures = [_load()]
    with tempfile.TemporaryDirectory() as cwd:
        for i, n in enumerate(cycles):
            cmd = _rig("run", "--config", str(EXAMPLE), "--emulate", "--duration", f"{n * PERIOD:g}")
            wall, _, mb = _child(cmd, cwd)
            figures += [
                {"name": f"rig_run_peak_rss_{n}_cycles", "value": round(mb, 1), "unit": "MB"},
                {"name": f"rig_run_wall_{n}_cycles", "value": round(wall, 1), "unit": "s"},
            ]
            if progress is not None:
                progress(i + 1, len(cycles))
    return [*figures, _load()]
