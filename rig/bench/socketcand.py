"""``rig bench socketcand``: ``rig emulate``'s socketcand server under connection churn and a flood.

Each figure comes from processes of their own on 127.0.0.1: ``rig emulate --preset dc-servo``
(real time, 1 kHz), a client process (``rig.bench.socketcand_clients``) and,
where a run is named, a real-time 1 kHz run of the section VII.B servo held at 0 rad
(``rig demo``'s configuration) in this process against the emulator.

- ``socketcand_connections_per_s``: a client that connects, waits for ``< hi >``, opens the bus,
  asks for rawmode, waits for both ``< ok >`` and closes, as fast as it can, during a run;
  ``socketcand_connection_failures`` those that failed, ``socketcand_handshake_max_ms`` the
  slowest; ``realtime_1khz_overruns_during_churn`` the run's overruns meanwhile;
- ``socketcand_burst_seconds``: ``BURST`` connections at once (a thread each), 2 s into a run,
  until all are done; ``socketcand_burst_failures``, and the run's overruns;
- ``realtime_1khz_overruns_quiet`` / ``realtime_1khz_overruns_churn``: the run's overruns
  without, and with, a client connecting ``CHURN_RATE`` times a second; ``PAIRS`` alternated
  pairs, the median of each (A/B in the same minutes);
- ``flood_<K>k_offered_per_s``, with the emulator's bus at K kbit/s (``FLOOD_BITRATES``):
  frames/s a client writes (``< send 7FF 8 ... >``) as fast as its socket takes them;
  ``..._delivered_per_s``: the rate at which a well-behaved reader (python-can's client through
  ``open_bus``, canopen) received them, first to last, and ``..._bus_per_s`` that of every
  frame on the bus meanwhile (the flood's, the reader's SDO requests and their answers,
  heartbeats: the flood's 0x7FF loses every arbitration to them), against
  ``..._ceiling_per_s`` (the bit rate over the frame's 135 bits, ``drivers.bus_time``);
  ``..._sdo_reads`` the SDO reads of 0x1000 the reader completed meanwhile, ``..._sdo_max_ms``
  the slowest, ``..._reader_dropped`` 1 if it lost its connection.

``load_1min`` is the machine's load average when the benchmark began.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import statistics
import tempfile
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import can

from rig.bench.micro import Figure
from rig.bench.socketcand_clients import client_process, client_result

if TYPE_CHECKING:
    from drivers.base import AxisDriver
    from rig.live.backend import Live

__all__ = [
    "BURST",
    "CHURN_RATE",
    "FLOOD_BITRATES",
    "PAIRS",
    "bench_socketcand",
    "flood_beside_reader",
    "flood_ceiling",
    "realtime_run",
]

CHURN_RATE = 200.0  #: [1/s] connections a second of the A/B runs
BURST = 200  #: connections at once
PAIRS = 3  #: alternated quiet/churn run pairs
RUN_SECONDS = 5.0  #: [s] each run
FLOOD_SECONDS = 4.0  #: [s] the flood
FLOOD_BITRATES = (1_000_000, 125_000)  #: [bit/s] the emulator's bus for each flood


def realtime_run(
    out: str,
    port: int,
    seconds: float,
    live: Live | None = None,
    started: Callable[[list[AxisDriver]], None] | None = None,
) -> dict[str, Any]:
    """A real-time 1 kHz run of the servo held at 0 rad against the emulator on ``port`` (``live``
    and ``started`` as ``rig.host.session.run_config`` takes them).

    Parameters
    ----------
    out : str
        The run's folder.
    port : int
        The emulator's socketcand port.
    seconds : float
        [s] of the run.
    live : Live | None, optional
        A live view (``run_config``'s).
    started : Callable[[list[AxisDriver]], None] | None, optional
        Called with the axes once set up (``run_config``'s).

    Returns
    -------
    dict[str, Any]
        The run's summary.
    """
    from rig.config import BusConfig, replace_axis
    from rig.host.session import run_config
    from rig.papers.demo import demo_config

    cfg = demo_config(out)
    cfg = dataclasses.replace(
        cfg,
        reference=dataclasses.replace(cfg.reference, kind="constant", value=0.0),
        run=dataclasses.replace(cfg.run, time="realtime", period=0.001),
        bus=BusConfig(interface="socketcand", channel="can0", port=port),
    )
    cfg = replace_axis(cfg, "motor", limits={"watchdog_periods": 1000})
    return run_config(cfg, emulate=False, duration=seconds, live=live, started=started)


class _Arrivals(can.Listener):
    """([s, monotonic], id) of every frame received, in ``came``."""

    def __init__(self) -> None:
        self.came: list[tuple[float, int]] = []

    def on_message_received(self, msg: can.Message) -> None:
        self.came.append((time.monotonic(), msg.arbitration_id))


def _reader(port: int, seconds: float, every: float) -> dict[str, Any]:
    """A well-behaved client for ``seconds`` [s]: SDO reads of node 1's 0x1000, one at most
    every ``every`` [s]. Between the first and the last 0x7FF frame it received: their rate
    (``frames_per_s``) and the rate of every frame on the bus (``bus_frames_per_s``: those it
    received and its own requests)."""
    import canopen
    from canopen.sdo.exceptions import SdoError

    from drivers.bus import open_bus
    from drivers.maps import CIA402_EDS

    network = canopen.Network(open_bus("socketcand", "can0", host="127.0.0.1", port=port))
    network.connect()
    arrivals = _Arrivals()
    assert network.notifier is not None
    network.notifier.add_listener(arrivals)
    node = canopen.RemoteNode(1, CIA402_EDS)
    network.add_node(node)
    node.sdo.RESPONSE_TIMEOUT = 2.0
    asked: list[float] = []  #: [s, monotonic] each request
    slowest, dropped = 0.0, 0
    start = time.monotonic()
    try:
        while time.monotonic() - start < seconds:
            if asked:
                time.sleep(max(0.0, asked[-1] + every - time.monotonic()))
            asked.append(time.monotonic())
            t0 = time.perf_counter()
            node.sdo.upload(0x1000, 0)
            slowest = max(slowest, time.perf_counter() - t0)
    except (can.CanError, OSError, SdoError):
        dropped = 1
    finally:
        with contextlib.suppress(Exception):
            network.disconnect()
    came = arrivals.came
    flood = [t for t, can_id in came if can_id == 0x7FF]
    window, on_bus = 0.0, 0
    if len(flood) > 1:
        window = flood[-1] - flood[0]
        on_bus = sum(flood[0] <= t <= flood[-1] for t, _ in came)
        on_bus += sum(flood[0] <= t <= flood[-1] for t in asked)
    return {
        "frames": len(flood),
        "frames_per_s": (len(flood) - 1) / window if window > 0.0 else 0.0,
        "bus_frames_per_s": on_bus / window if window > 0.0 else 0.0,
        "reads": len(asked) - dropped,
        "slowest_ms": slowest * 1e3,
        "dropped": dropped,
    }


def _with_emulator(use: Callable[[int], list[Figure]], *args: str) -> list[Figure]:
    """``use(port)`` with ``rig emulate --preset dc-servo`` at 1 kHz (and ``args``) beside."""
    from rig.emulator.spawn import spawn_emulator, stop_rig

    proc, port = spawn_emulator("--preset", "dc-servo", "--param", "period=0.001", *args)
    try:
        return use(port)
    finally:
        stop_rig(proc, timeout=20)


def _churn_figures(port: int) -> list[Figure]:
    with tempfile.TemporaryDirectory() as out:
        client = client_process("churn", port, RUN_SECONDS)
        summary = realtime_run(out, port, RUN_SECONDS)
        result = client_result(client)
        client = client_process("burst", port, 2.0, BURST)  # 2 s into the run
        burst_summary = realtime_run(out, port, RUN_SECONDS)
        at_once = client_result(client)
        quiet, busy = [], []
        for _ in range(PAIRS):
            quiet.append(realtime_run(out, port, RUN_SECONDS)["overruns"])
            client = client_process("churn", port, RUN_SECONDS, CHURN_RATE)
            busy.append(realtime_run(out, port, RUN_SECONDS)["overruns"])
            client_result(client)
    return [
        {"name": "socketcand_connections_per_s", "value": round(result["connections"] / result["seconds"])},
        {"name": "socketcand_connection_failures", "value": result["failed"], "unit": "connections"},
        {"name": "socketcand_handshake_max_ms", "value": round(result["slowest_ms"], 1), "unit": "ms"},
        {"name": "realtime_1khz_overruns_during_churn", "value": summary["overruns"], "unit": "cycles"},
        {
            "name": "socketcand_burst_seconds",
            "value": round(at_once["seconds"], 3),
            "unit": f"s ({BURST} at once)",
        },
        {"name": "socketcand_burst_failures", "value": at_once["failed"], "unit": "connections"},
        {"name": "realtime_1khz_overruns_during_burst", "value": burst_summary["overruns"], "unit": "cycles"},
        {"name": "realtime_1khz_overruns_quiet", "value": statistics.median(quiet), "unit": "cycles"},
        {"name": "realtime_1khz_overruns_churn", "value": statistics.median(busy), "unit": "cycles"},
        {"name": "realtime_1khz_overruns_pairs", "value": f"{quiet} / {busy}", "unit": "cycles"},
    ]


def flood_ceiling(bitrate: float) -> float:
    """[frames/s] the flood's 8-byte frames a bus of ``bitrate`` [bit/s] carries at most.

    Parameters
    ----------
    bitrate : float
        [bit/s].

    Returns
    -------
    float
        [frames/s].
    """
    from drivers.bus_time import frame_bits

    return bitrate / frame_bits(can.Message(arbitration_id=0x7FF, is_extended_id=False, dlc=8))


def flood_beside_reader(port: int, bitrate: int) -> tuple[dict[str, Any], dict[str, Any]]:
    """A flood of ``FLOOD_SECONDS`` from another process while a reader reads (``_reader``):
    (the flood's result, the reader's). The reader asks for at most half of what a bus of
    ``bitrate`` [bit/s] carries (a request and its answer: two frames): its requests win every
    arbitration, so a reader as fast as its machine lets it (about 460 reads/s fill 125 kbit/s)
    would leave the flood no frame at all, which is the bus's rule and not what is measured.

    Parameters
    ----------
    port : int
        The server's port on 127.0.0.1.
    bitrate : int
        [bit/s] the server's bus.

    Returns
    -------
    tuple[dict[str, Any], dict[str, Any]]
        (the flood's result, the reader's).
    """
    every = 2.0 / (0.5 * flood_ceiling(bitrate))
    got: dict[str, Any] = {}
    reader = threading.Thread(target=lambda: got.update(_reader(port, FLOOD_SECONDS + 2.0, every)))
    reader.start()
    time.sleep(1.0)  # the reader is connected and reading
    offered = client_result(client_process("flood", port, FLOOD_SECONDS))
    reader.join()
    return offered, got


def _flood_figures(bitrate: int) -> Callable[[int], list[Figure]]:
    def figures(port: int) -> list[Figure]:
        offered, got = flood_beside_reader(port, bitrate)
        at = f"flood_{bitrate // 1000}k"
        return [
            {"name": f"{at}_offered_per_s", "value": round(offered["frames_per_s"])},
            {"name": f"{at}_delivered_per_s", "value": round(got["frames_per_s"])},
            {"name": f"{at}_bus_per_s", "value": round(got["bus_frames_per_s"])},
            {"name": f"{at}_ceiling_per_s", "value": round(flood_ceiling(bitrate))},
            {"name": f"{at}_sdo_reads", "value": got["reads"], "unit": "reads"},
            {"name": f"{at}_sdo_max_ms", "value": round(got["slowest_ms"], 1), "unit": "ms"},
            {"name": f"{at}_reader_dropped", "value": got["dropped"], "unit": ""},
        ]

    return figures


def bench_socketcand(progress: Callable[[int, int], None] | None = None) -> list[Figure]:
    """See the module docstring; ``progress(step, steps)`` after the churn and after each flood.

    Parameters
    ----------
    progress : Callable[[int, int], None] | None, optional
        ``progress(step, steps)``.

    Returns
    -------
    list[Figure]
        The figures.
    """
    figures: list[Figure] = [{"name": "load_1min", "value": round(os.getloadavg()[0], 2), "unit": ""}]
    figures += _with_emulator(_churn_figures)
    if progress is not None:
        progress(1, 1 + len(FLOOD_BITRATES))
    for n, bitrate in enumerate(FLOOD_BITRATES, start=2):
        figures += _with_emulator(_flood_figures(bitrate), "--bitrate", str(bitrate))
        if progress is not None:
            progress(n, 1 + len(FLOOD_BITRATES))
    for figure in figures:
        figure.setdefault("unit", "1/s")
    return figures
