"""``rig bench stops``: false stops of real-time runs across processes.

``runs`` runs of ``seconds`` each of ``examples/dc_servo_position.toml`` in real time at
1 kHz (the example's limits and watchdog; ``[run] time = "realtime"``, ``period = 0.001``),
each against a fresh ``rig emulate`` of the example's ``[emulator]`` (the dc-servo preset, its
load step) at 1 kHz in another process over socketcand (127.0.0.1). Any safe stop is a false
one: nothing is injected. Figures: the runs, the false stops, and over the runs the medians of
the overruns and of the p99 and max period error and host response time.
"""

from __future__ import annotations

import dataclasses
import logging
import statistics
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rig.bench.micro import Figure
from rig.config import BusConfig, load_config
from rig.host.session import Session
from rig.process import spawn_emulator, stop_rig

__all__ = ["EXAMPLE", "bench_stops"]

log = logging.getLogger(__name__)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _run(out: str, seconds: float) -> dict[str, Any]:
    cfg = load_config(EXAMPLE)
    params = {**cfg.emulator.params, "period": "0.001"}  # the example's load step, at 1 kHz
    proc, port = spawn_emulator(
        "--preset", cfg.emulator.preset, *(a for k, v in params.items() for a in ("--param", f"{k}={v}"))
    )
    try:
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, time="realtime", period=0.001, output=out),
            bus=BusConfig(interface="socketcand", channel="can0", port=port),
        )
        with Session(cfg, emulate=False, duration=seconds) as session:
            session.start()
            return session.run()
    finally:
        stop_rig(proc, timeout=10)


def bench_stops(
    *, runs: int = 20, seconds: float = 10.0, progress: Callable[[int, int], None] | None = None
) -> list[Figure]:
    """See the module docstring; ``progress(run, runs)`` after each run."""
    summaries = []
    with tempfile.TemporaryDirectory() as out:
        for n in range(runs):
            summary = _run(out, seconds)
            summaries.append(summary)
            log.info("run %d/%d: %s", n + 1, runs, summary["safe_stop_reason"] or "no stop")
            if progress is not None:
                progress(n + 1, runs)
    stops = [s["safe_stop_reason"] for s in summaries if s["safe_stop_reason"]]

    def median(key: str) -> float:
        return round(statistics.median(float(s["timing"].get(key, float("nan"))) for s in summaries), 1)

    return [
        {"name": "realtime_1khz_runs", "value": runs, "unit": f"runs of {seconds:g} s"},
        {"name": "realtime_1khz_false_stops", "value": len(stops), "unit": "runs"},
        *({"name": "false_stop", "value": reason, "unit": ""} for reason in stops),
        {
            "name": "realtime_1khz_overruns_median",
            "value": statistics.median(s["overruns"] for s in summaries),
            "unit": "cycles",
        },
        *(
            {"name": f"realtime_1khz_{key[:-3]}_median", "value": median(key), "unit": "us"}
            for key in ("period_error_p99_us", "period_error_max_us", "response_p99_us", "response_max_us")
        ),
    ]
