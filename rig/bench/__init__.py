"""Benchmarks: ``rig bench NAME`` -> a list of {"name", "value", "unit"}; never part of the test run.

Each entry imports its module when it runs, so ``rig --help`` does not import what a
benchmark measures (numpy, the controllers, the plants, Dask).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rig.bench.micro import Figure

__all__ = ["BENCHMARKS", "LONG"]

#: ``progress(done, total)`` of a long benchmark
Progress = Callable[[int, int], None]


def _controllers() -> list[Figure]:
    """Microseconds per ``step`` of each controller (target <= 5 us)."""
    from rig.bench.micro import bench_controllers

    return bench_controllers()


def _plant() -> list[Figure]:
    """Microseconds per exact ZOH step of the plant models."""
    from rig.bench.micro import bench_plant

    return bench_plant()


def _physics() -> list[Figure]:
    """Physics steps per second of each preset's axis, and lock-step emulator cycles per second."""
    from rig.bench.micro import bench_physics

    return bench_physics()


def _identify() -> list[Figure]:
    """Accuracy of ``rig identify`` over 30 experiments on the dc-servo physics (3.4)."""
    from rig.bench.micro import bench_identify

    return bench_identify()


def _loop() -> list[Figure]:
    from rig.bench.loop import bench_loop

    return bench_loop()


def _soak(progress: Progress | None = None) -> list[Figure]:
    from rig.bench.soak import bench_soak

    return bench_soak(progress=progress)


def _stops(progress: Progress | None = None, **options: Any) -> list[Figure]:
    from rig.bench.stops import bench_stops

    return bench_stops(progress=progress, **options)


def _socketcand(progress: Progress | None = None) -> list[Figure]:
    from rig.bench.socketcand import bench_socketcand

    return bench_socketcand(progress=progress)


def _sweep(progress: Progress | None = None) -> list[Figure]:
    """points/s of a sweep at 1 and 2 local workers, scaling, overhead per point, 100 workers (minutes)"""
    from rig.bench.sweep import bench_sweep

    return bench_sweep(progress=progress)


def _startup() -> list[Figure]:
    """wall and CPU seconds of rig --version and of a 0.1 s emulated rig run (fresh processes, 7 each)"""
    from rig.bench.costs import bench_startup

    return bench_startup()


def _memory(progress: Progress | None = None) -> list[Figure]:
    """peak memory of an emulated rig run at 25,000 and 250,000 cycles (about 2 minutes)"""
    from rig.bench.costs import bench_memory

    return bench_memory(progress=progress)


def _view(progress: Progress | None = None, **options: Any) -> list[Figure]:
    from rig.bench.view import bench_view

    return bench_view(progress=progress, **options)


_loop.__doc__ = (
    "full-chain lock-step cycles/s (one axis, the dyno, the bare canopen exchange), 1 kHz real time"
)
_soak.__doc__ = "1,000,000 lock-step cycles with 1 % frame loss: memory growth and stops (minutes)"
_stops.__doc__ = (
    "false stops, overruns, late cycles, period error and SYNC-to-RPDO response in 20 real-time runs "
    "of 10 s of examples/dc_servo_position_rt.toml (its lean process image) against rig emulate over "
    "socketcand, at --period (1 ms) under --load busy processes (minutes)"
)
_socketcand.__doc__ = (
    "rig emulate's socketcand server: connections/s during a real-time run, the run's overruns "
    "with and without 200 connections/s, a flood held to the bit rate and a reader kept (minutes)"
)

_view.__doc__ = (
    "overruns, late cycles, period error and response of 1 kHz real-time runs without a view, with "
    "rig run --view and a browser on this machine (headless Chromium), and with the view read from "
    "elsewhere (a websocket client drawing nothing), --runs rounds (5) of --seconds (10) alternated "
    "in the same minutes (minutes)"
)

#: ``rig bench NAME`` -> function returning a list of {"name", "value", "unit"}
BENCHMARKS: dict[str, Callable[[], list[Figure]]] = {
    "controllers": _controllers,
    "plant": _plant,
    "physics": _physics,
    "loop": _loop,
    "identify": _identify,
    "soak": _soak,
    "stops": _stops,
    "socketcand": _socketcand,
    "sweep": _sweep,
    "startup": _startup,
    "memory": _memory,
    "view": _view,
}
#: the benchmarks that take minutes and take a ``progress`` callback
LONG = {
    "soak": _soak,
    "stops": _stops,
    "socketcand": _socketcand,
    "sweep": _sweep,
    "memory": _memory,
    "view": _view,
}
