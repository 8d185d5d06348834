"""The clients of ``rig bench socketcand`` (``rig.bench.socketcand``), each run in a process of its
own (``client_process``: ``python -m rig.bench.socketcand_clients churn|connects|burst|hold|flood
PORT SECONDS [RATE]``) against ``rig emulate``'s socketcand server on 127.0.0.1, its JSON result
on stdout: connection churn, a burst of connections at once, clients held in rawmode, a flood of
frames.
"""

from __future__ import annotations

import contextlib
import json
import selectors
import socket
import subprocess
import sys
import threading
import time
from typing import Any

__all__ = ["burst", "churn", "client_process", "client_result", "flood", "hold"]

_FLOOD_LINE = b"< send 7FF 8 01 02 03 04 05 06 07 08 >"


def _handshake(port: int) -> None:
    """One connection: ``< hi >``, open, rawmode, both ``< ok >``, close (3 s at most)."""
    with socket.create_connection(("127.0.0.1", port), timeout=3.0) as link:
        got = b""
        while b"< hi >" not in got:
            chunk = link.recv(4096)
            if not chunk:
                raise ConnectionError(f"closed before '< hi >': {got!r}")
            got += chunk
        link.sendall(b"< open can0 >< rawmode >")
        while got.count(b"< ok >") < 2:
            chunk = link.recv(4096)
            if not chunk:
                raise ConnectionError(f"closed before the second '< ok >': {got[-80:]!r}")
            got += chunk


def churn(port: int, seconds: float, rate: float = 0.0, count: int = 0) -> dict[str, Any]:
    """Connections one after another: how many, how many failed, the slowest handshake [ms].

    Parameters
    ----------
    port : int
        The server's port on 127.0.0.1.
    seconds : float
        [s].
    rate : float, optional
        [1/s] connections (0: as fast as they go).
    count : int, optional
        The most connections (0: no limit).

    Returns
    -------
    dict[str, Any]
        ``connections``, ``failed``, ``slowest_ms``.
    """
    done = failed = 0
    slowest = 0.0
    start = time.monotonic()
    while (now := time.monotonic()) - start < seconds and not 0 < count <= done + failed:
        if rate > 0.0:
            due = start + (done + failed) / rate
            if due > now:
                time.sleep(due - now)
        t0 = time.perf_counter()
        try:
            _handshake(port)
            done += 1
        except OSError:
            failed += 1
        slowest = max(slowest, time.perf_counter() - t0)
    elapsed = time.monotonic() - start
    return {"connections": done, "failed": failed, "seconds": elapsed, "slowest_ms": slowest * 1e3}


def burst(port: int, count: int) -> dict[str, Any]:
    """``count`` connections at once, each a thread of its own: how long until all were done
    [s], how many failed, the slowest [ms].

    Parameters
    ----------
    port : int
        The server's port on 127.0.0.1.
    count : int
        Connections at once.

    Returns
    -------
    dict[str, Any]
        ``seconds``, ``failed``, ``slowest_ms``.
    """
    failed: list[str] = []
    slowest = [0.0]

    def one() -> None:
        t0 = time.perf_counter()
        try:
            _handshake(port)
        except OSError as exc:
            failed.append(str(exc))
        slowest[0] = max(slowest[0], time.perf_counter() - t0)

    threads = [threading.Thread(target=one) for _ in range(count)]
    start = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    elapsed = time.perf_counter() - start
    return {
        "connections": count - len(failed),
        "failed": len(failed),
        "seconds": elapsed,
        "slowest_ms": slowest[0] * 1e3,
    }


def hold(port: int, seconds: float, count: int) -> dict[str, Any]:
    """``count`` clients in rawmode at once for ``seconds`` [s], each reading every frame it is
    sent (a bus with that many listeners): how many were held to the end, and frames read.

    Parameters
    ----------
    port : int
        The server's port on 127.0.0.1.
    seconds : float
        [s].
    count : int
        Clients.

    Returns
    -------
    dict[str, Any]
        ``held`` and ``frames``.
    """
    links = [socket.create_connection(("127.0.0.1", port), timeout=10.0) for _ in range(count)]
    with selectors.DefaultSelector() as selector:
        for link in links:
            link.sendall(b"< open can0 >< rawmode >")
            link.setblocking(False)
            selector.register(link, selectors.EVENT_READ, link)
        frames, end = 0, time.monotonic() + seconds
        while time.monotonic() < end:
            for key, _ in selector.select(0.1):
                try:
                    chunk = key.data.recv(65536)
                except BlockingIOError:
                    continue
                except OSError:  # dropped by the server
                    chunk = b""
                frames += chunk.count(b"< frame ")
                if not chunk:
                    selector.unregister(key.data)
        held = len(selector.get_map())
    for link in links:
        link.close()
    return {"held": held, "frames": frames}


def flood(port: int, seconds: float) -> dict[str, Any]:
    """``< send 7FF 8 ... >`` as fast as the socket takes them for ``seconds`` [s] (what comes
    back is read and thrown away): how many were written, per second.

    Parameters
    ----------
    port : int
        The server's port on 127.0.0.1.
    seconds : float
        [s].

    Returns
    -------
    dict[str, Any]
        ``written`` and per second.

    Raises
    ------
    ConnectionError
        If the server closes during the handshake.
    """
    link = socket.create_connection(("127.0.0.1", port), timeout=10.0)
    got = b""
    while got.count(b"< ok >") < 2:
        if b"< hi >" in got and b"open" not in got:
            link.sendall(b"< open can0 >< rawmode >")
            got += b"open"
        chunk = link.recv(4096)
        if not chunk:
            raise ConnectionError("closed during the handshake")
        got += chunk

    def drain() -> None:
        with contextlib.suppress(OSError):
            while link.recv(65536):
                pass

    threading.Thread(target=drain, daemon=True).start()
    # the server holds a flood back to the bit rate: a write may wait, on a loaded PC over 10 s
    link.settimeout(seconds + 30.0)
    batch, per = _FLOOD_LINE * 100, 100
    sent = 0
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        link.sendall(batch)
        sent += per
    elapsed = time.monotonic() - start
    link.close()
    return {"frames": sent, "seconds": elapsed, "frames_per_s": sent / elapsed}


def client_process(kind: str, port: int, seconds: float, rate: float = 0.0) -> subprocess.Popen[str]:
    """``churn`` (``rate``), ``connects`` (``rate`` of them), ``burst`` (``rate`` connections at
    once, after ``seconds``), ``hold`` (``rate`` clients) or ``flood`` in a process of its own;
    its JSON result is its stdout.

    Parameters
    ----------
    kind : str
        churn, connects, burst, hold or flood.
    port : int
        The server's port on 127.0.0.1.
    seconds : float
        [s].
    rate : float, optional
        As ``kind`` takes it.

    Returns
    -------
    subprocess.Popen[str]
        The process.
    """
    return subprocess.Popen(
        [sys.executable, "-m", "rig.bench.socketcand_clients", kind, str(port), str(seconds), str(rate)],
        stdout=subprocess.PIPE,
        text=True,
    )


def client_result(proc: subprocess.Popen[str]) -> dict[str, Any]:
    """The JSON result of a ``client_process``.

    Parameters
    ----------
    proc : subprocess.Popen[str]
        The process.

    Returns
    -------
    dict[str, Any]
        Its result.

    Raises
    ------
    RuntimeError
        If it exited with an error.
    """
    out, _ = proc.communicate(timeout=120)
    if proc.returncode != 0:
        raise RuntimeError(f"the benchmark's client exited {proc.returncode}")
    result: dict[str, Any] = json.loads(out)
    return result


def main(argv: list[str]) -> int:
    """``churn|connects|burst|hold|flood PORT SECONDS [RATE]``: one client's JSON result on stdout
    (``connects``: RATE connections one after another, as fast as they go; ``hold``: RATE clients
    in rawmode for SECONDS)."""
    kind, port, seconds = argv[0], int(argv[1]), float(argv[2])
    rate = float(argv[3]) if len(argv) > 3 else 0.0
    if kind == "churn":
        result = churn(port, seconds, rate)
    elif kind == "connects":
        result = churn(port, seconds, count=int(rate))
    elif kind == "hold":
        result = hold(port, seconds, int(rate))
    elif kind == "burst":
        time.sleep(seconds)
        result = burst(port, int(rate))
    else:
        result = flood(port, seconds)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
