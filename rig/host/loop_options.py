"""How a host loop runs beside its axes, law and timebase: what the session takes from ``[run]``,
the axes' limits and the transport (``rig.host.loop.HostLoop``'s ``options``)."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any

__all__ = ["LoopOptions"]


@dataclass(frozen=True)
class LoopOptions:
    """The loop's options; the defaults are a lock-step run's without heartbeat or watches."""

    stop_timeout: float = 3.0  #: [s] for the drives' ramps at the end
    heartbeat: Callable[[int], None] | None = None  #: the host's heartbeat, ``heartbeat(k)`` every cycle
    on_stop: Callable[[], None] | None = None  #: called as the stop begins (later signals do not cut it)
    missed_sample: str = "hold"  #: "hold" | "zero": a cycle without a new sample (``[run] missed_sample``)
    #: the section a stop signal waits for (``StopRequests.held``): a cycle's row and count
    held: AbstractContextManager[None] | None = None
    late_stop: int = 0  #: that many late cycles in a row: a safe stop (0: never)
    #: [s] before a deadline the loop stops sleeping and spins yielding (0: sleeps to it; never at
    #: real-time priority, where a spin starves the threads that carry the frames)
    spin: float = 0.0004
    producers: Any = None  #: another producer's watch (``drivers.producer_watch.ProducerWatch``)
