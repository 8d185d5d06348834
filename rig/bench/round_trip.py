"""The machine's floor for a SYNC's answer across processes: one frame's round trip over TCP on
127.0.0.1 between two processes with the host's and the emulator's real-time requests.

``rig bench stops`` measures the response of a real-time run against ``rig emulate`` in another
process: the SYNC goes over socketcand to the emulator, the TPDO comes back, the host's RPDO goes
out. Part of it is the machine's, whatever the toolkit does: two wake-ups of a process blocked on
its socket (one per direction; on a virtual machine each may cost the hypervisor's interrupt
delivery) and the kernel's loopback. ``round_trip_floor`` measures that part alone: this process,
under the host loop's request (``RealtimeRequest()``: SCHED_FIFO 50 on the last CPU, memory
locked, the CPU latency held at 0 us), sends a line the size of a socketcand frame at deadlines
``period`` apart (the loop's ``sleep_until``), and an echo process under the emulator's request
(``rig emulate``'s defaults: SCHED_FIFO 49 on CPU 0) sends it back at once; each round trip, from
the send to the echo received, is recorded. A drive's answer can be no shorter than it, nor a
response.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from typing import Any

from rig.bench.floor import periods_in, under_the_loops_scheduling
from rig.host.cycle_clock import sleep_until
from rig.host.realtime import RealtimeRequest

__all__ = ["round_trip_floor"]

#: a socketcand frame line of a 6-byte TPDO, the size of what the runs carry
LINE = b"< frame 181 1764288000.000000 0011223344AA >"
#: the echo's request: ``rig emulate``'s defaults (SCHED_FIFO 49, CPU 0)
ECHO = RealtimeRequest(priority=49, cpu=0)


def round_trip_floor(period: float, seconds: float) -> dict[str, Any]:
    """Round trips ``period`` [s] apart for ``seconds`` [s] against an echo process (module
    docstring): ``periods``, ``round_trip_us`` (median, p99, max) and ``granted`` (this
    process's, in one line).

    Parameters
    ----------
    period : float
        [s] between sends, > 0.
    seconds : float
        [s] of round trips, >= ``period``.

    Returns
    -------
    dict[str, Any]
        ``periods``, ``round_trip_us``, ``granted``.

    Raises
    ------
    ValueError
        If not 0 < ``period`` <= ``seconds``.
    RuntimeError
        If the echo process did not start.
    """
    n = periods_in(period, seconds)
    with socket.create_server(("127.0.0.1", 0)) as listener:
        echo = subprocess.Popen(
            [sys.executable, "-m", "rig.bench.round_trip", str(listener.getsockname()[1])],
            stdin=subprocess.DEVNULL,
        )
        listener.settimeout(30.0)
        try:
            link, _ = listener.accept()
        except OSError as exc:
            echo.kill()
            echo.wait()
            raise RuntimeError(f"the round trip's echo process did not connect: {exc}") from exc
    try:
        link.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        link.settimeout(10.0)
        trips, grant = _trips(link, period, n)
    finally:
        link.close()
        echo.wait(timeout=30.0)
    xs = sorted(trips)
    return {
        "periods": n,
        "round_trip_us": {
            "median": xs[len(xs) // 2] * 1e6,
            "p99": xs[int(0.99 * (len(xs) - 1))] * 1e6,
            "max": xs[-1] * 1e6,
        },
        "granted": grant,
    }


def _trips(link: socket.socket, period: float, n: int) -> tuple[list[float], str]:
    """``n`` round trips on ``link`` at deadlines ``period`` [s] apart under the host's request:
    each [s], and what was granted."""
    trips = [0.0] * n
    with under_the_loops_scheduling() as grant:
        deadline = time.perf_counter() + period
        for k in range(n):
            sleep_until(deadline)
            sent = time.perf_counter()
            link.sendall(LINE)
            got = 0
            while got < len(LINE):
                chunk = link.recv(len(LINE) - got)
                if not chunk:
                    raise RuntimeError("the round trip's echo process hung up")
                got += len(chunk)
            trips[k] = time.perf_counter() - sent
            deadline = max(deadline + period, time.perf_counter())
    return trips, grant.describe()


def _echo(port: int) -> None:
    """The echo process: connect to ``port`` on 127.0.0.1 under ``ECHO`` and send back what comes
    until the other end hangs up."""
    with (
        under_the_loops_scheduling(ECHO),
        socket.create_connection(("127.0.0.1", port), timeout=30.0) as link,
    ):
        link.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        link.settimeout(None)
        while chunk := link.recv(4096):
            link.sendall(chunk)


if __name__ == "__main__":
    _echo(int(sys.argv[1]))
