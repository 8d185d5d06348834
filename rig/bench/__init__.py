"""Benchmarks: ``rig bench NAME`` -> a list of {"name", "value", "unit"}; never part of the test run."""

from __future__ import annotations

from collections.abc import Callable

from rig.bench.micro import Figure, bench_controllers, bench_identify, bench_physics, bench_plant

__all__ = ["BENCHMARKS", "LONG", "Figure"]

#: ``progress(done, total)`` of a long benchmark
Progress = Callable[[int, int], None]


def _loop() -> list[Figure]:
    from rig.bench.loop import bench_loop

    return bench_loop()


def _soak(progress: Progress | None = None) -> list[Figure]:
    from rig.bench.soak import bench_soak

    return bench_soak(progress=progress)


def _stops(progress: Progress | None = None) -> list[Figure]:
    from rig.bench.stops import bench_stops

    return bench_stops(progress=progress)


_loop.__doc__ = (
    "full-chain lock-step cycles/s (one axis, the dyno, the bare canopen exchange), 1 kHz real time"
)
_soak.__doc__ = "1,000,000 lock-step cycles with 1 % frame loss: memory growth and stops (minutes)"
_stops.__doc__ = (
    "false stops in 20 real-time runs of 10 s at 1 kHz of examples/dc_servo_position.toml against "
    "rig emulate over socketcand (minutes)"
)

#: ``rig bench NAME`` -> function returning a list of {"name", "value", "unit"}
BENCHMARKS: dict[str, Callable[[], list[Figure]]] = {
    "controllers": bench_controllers,
    "plant": bench_plant,
    "physics": bench_physics,
    "loop": _loop,
    "identify": bench_identify,
    "soak": _soak,
    "stops": _stops,
}
#: the benchmarks that take minutes and take a ``progress`` callback
LONG = {"soak": _soak, "stops": _stops}
