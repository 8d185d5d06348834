"""``rig bench soak``: a million lock-step cycles of the servo with frame loss; memory and stops."""

from __future__ import annotations

import dataclasses
import gc
import os
import tempfile
import time
from collections.abc import Callable

from rig.bench.micro import Figure
from rig.config import replace_axis
from rig.host.session import Session
from rig.papers.demo import demo_config

__all__ = ["bench_soak"]


def _rss_bytes() -> int:
    """Resident set size of this process [bytes] (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def bench_soak(
    *, cycles: int = 1_000_000, frame_loss: float = 0.01, progress: Callable[[int, int], None] | None = None
) -> list[Figure]:
    """The lock-step soak: the section VII.B servo over the emulated bus for ``cycles`` cycles with
    ``frame_loss`` of the frames lost (about 2-3 minutes). Memory is the RSS at 10 % of the run and
    at its last cycle; the watchdog tolerates 10 lost TPDOs in a row, so a stop would be a real one.

    Parameters
    ----------
    cycles : int, optional
        Cycles of the run.
    frame_loss : float, optional
        Fraction of frames lost.
    progress : Callable[[int, int], None] | None, optional
        ``progress(done, total)`` during the run.

    Returns
    -------
    list[Figure]
        The figures (cycles, stops, memory).
    """
    rss: dict[str, int] = {}

    def measure(k: int) -> None:
        if progress is not None:
            progress(k, cycles)
        if k in (cycles // 10, cycles):  # the end is measured before the recorder's close
            gc.collect()
            rss["early" if k == cycles // 10 else "end"] = _rss_bytes()

    with tempfile.TemporaryDirectory() as out:
        cfg = demo_config(out)
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, trace="none"),
            reference=dataclasses.replace(cfg.reference, kind="constant", value=0.0),
            faults=dataclasses.replace(cfg.faults, frame_loss=frame_loss, seed=1),
        )
        cfg = replace_axis(cfg, "motor", limits={"watchdog_periods": 10})
        t0 = time.perf_counter()
        with Session(cfg, emulate=True, cycles=cycles) as session:
            session.start()
            summary = session.run(measure)
        elapsed = time.perf_counter() - t0
    early, end = rss.get("early", 0), rss.get("end", 0)
    growth = 100.0 * (end - early) / early if early and end else float("nan")
    return [
        {"name": "soak_cycles", "value": summary["cycles"], "unit": "cycles"},
        {"name": "soak_frame_loss", "value": frame_loss, "unit": ""},
        {"name": "soak_rss_at_10_percent", "value": round(early / 2**20, 1), "unit": "MiB"},
        {"name": "soak_rss_at_last_cycle", "value": round(end / 2**20, 1), "unit": "MiB"},
        {"name": "soak_memory_growth", "value": round(growth, 2), "unit": "%"},
        {"name": "soak_safe_stop", "value": summary["safe_stop_reason"] or "none", "unit": ""},
        {"name": "soak_wall_time", "value": round(elapsed, 1), "unit": "s"},
    ]
