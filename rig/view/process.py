"""The view's server in a process of its own beside a run (``rig run --view``, ``rig bench view``).

The run's process keeps only the shared ring its recorder writes (``rig.view.beside``); over a
pipe (``PipeSink``) it sends the run's description, the ring (its file descriptor) and the stop,
nothing per update. The reading of the ring ``RATE`` times a second, its decimation, the axes'
states (``rig.view.ring_pump``), the server, its event loop, the JSON for the browsers and every
request (a hostile one too) are the other process's, which never holds the run's interpreter
lock: work of the view in the run's own process, holding the lock while the machine's other
processes ran, kept the real-time loop waiting (its figures: docs/benchmarks.md, "The view").

The child steps aside first (``step_aside``): the normal policy at nice ``NICE``, on the CPUs
the loop is not pinned to, for itself and every thread it starts (the server's, uvicorn's); a
browser's requests then never take the loop's CPU, and any other work of the machine comes
before them.

The child binds the address (a port in use: ConfigError in the run's process before anything
moves), ignores Ctrl-C (the run's to handle: the page then gets the run's summary), serves from
a thread of its own, and ends when the run's process says so or its pipe closes.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Mapping
from multiprocessing import reduction
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError

__all__ = ["NICE", "PipeSink", "ViewProcess", "serve_child", "step_aside"]

log = logging.getLogger(__name__)

NICE = 10  #: the view's process's niceness (at least)


def step_aside(loop_cpu: int | None) -> None:
    """The calling thread, and the threads it starts after, at the normal policy, nice ``NICE``
    (at least) and off ``loop_cpu`` (None: any CPU). A refusal leaves that measure out.

    Parameters
    ----------
    loop_cpu : int | None
        The CPU the run's loop is pinned to (``rig.host.realtime.loop_cpu``), or None.
    """
    if not hasattr(os, "sched_setscheduler"):
        return
    try:
        if os.sched_getscheduler(0) != os.SCHED_OTHER:  # a parent at real-time priority: not ours
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        if os.getpriority(os.PRIO_PROCESS, 0) < NICE:  # this thread's, on Linux
            os.setpriority(os.PRIO_PROCESS, 0, NICE)
        others = os.sched_getaffinity(0) - {loop_cpu}
        if loop_cpu is not None and others:
            os.sched_setaffinity(0, others)
    except OSError as exc:
        log.debug("the view's process did not step aside: %s", exc)


def serve_child(
    conn: Any, folders: list[str], host: str, port: int, where: str, *, loop_cpu: int | None = None
) -> None:
    """The child: ("url", url) or ("error", text) on ``conn``, then serve what comes over it:
    ("open", meta), ("ring", layout, names) and the ring's descriptor (``PipeSink.ring``: a thread
    here then reads it, ``rig.view.ring_pump``), ("stop",), ("finish", summary, grace).

    Parameters
    ----------
    conn : Any
        The pipe to the parent.
    folders : list[str]
        The folders served.
    host, port
        The address.
    where : str
        The option, named in errors.
    loop_cpu : int | None, optional
        The CPU the run's loop is pinned to (``step_aside``).
    """
    step_aside(loop_cpu)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from rig.view.scope import Scope
    from rig.view.server import ViewServer

    scope = Scope()
    pump: Any = None
    try:
        server = ViewServer([Path(f) for f in folders], scope, host, port, where)
    except ConfigError as exc:
        conn.send(("error", str(exc)))
        return
    conn.send(("url", server.url))
    server.start()
    try:
        while True:
            msg = conn.recv()
            if msg[0] == "open":
                scope.open(msg[1])
            elif msg[0] == "ring":  # the run's shared ring: its descriptor follows
                pump = _pump(scope, reduction.recv_handle(conn), msg[1], msg[2])
            elif msg[0] == "stop":
                pump, stopping = None, pump
                if stopping is not None:
                    stopping.stop()  # the last rows, then the scope stops
                else:
                    scope.stop()
            elif msg[0] == "finish":
                server.finish(msg[1], msg[2])
                conn.send(("done",))
                return
    except (EOFError, OSError):  # the run's process is gone
        if pump is not None:
            pump.stop()
        scope.stop()
    finally:
        server.close()


def _pump(scope: Any, fd: int, layout: tuple[int, int, int], names: list[str]) -> Any:
    """A ``rig.view.ring_pump.RingPump`` started on the ring ``fd`` of ``layout`` into ``scope``."""
    from rig.live.shared_ring import Layout, RingReader
    from rig.view.feed import RATE
    from rig.view.ring_pump import RingPump

    pump = RingPump(scope, RingReader(fd, Layout(*layout)), names, RATE)
    pump.start()
    return pump


class PipeSink:
    """What the run's process sends the child (``rig.view.beside.SharedView``): ``open``, ``ring``
    and ``stop``, nothing per update. A child that is gone is logged once; the run goes on.

    Parameters
    ----------
    conn : Any
        The pipe to the child.
    """

    def __init__(self, conn: Any) -> None:
        self._conn = conn
        self.failed = False

    def _send(self, msg: tuple[Any, ...]) -> None:
        if self.failed:
            return
        try:
            self._conn.send(msg)
        except (OSError, EOFError, ValueError) as exc:
            self.failed = True
            log.warning("the view's process is gone (%s); the run goes on", exc)

    def open(self, meta: dict[str, Any]) -> None:
        """Send ``open``.

        Parameters
        ----------
        meta : dict[str, Any]
            The run's description.
        """
        self._send(("open", meta))

    def ring(self, fd: int, layout: tuple[int, int, int], names: list[str]) -> None:
        """Send the run's shared ring: its layout and axes, then its descriptor (``SCM_RIGHTS``).

        Parameters
        ----------
        fd : int
            The ring's file descriptor (the caller's, still open after).
        layout : tuple[int, int, int]
            ``rig.live.shared_ring.Layout.args()``.
        names : list[str]
            The axes whose state columns follow each row.
        """
        self._send(("ring", layout, names))
        if self.failed:
            return
        try:
            reduction.send_handle(self._conn, fd, 0)  # the pid is Windows's only
        except OSError as exc:
            self.failed = True
            log.warning("the view's process is gone (%s); the run goes on", exc)

    def stop(self) -> None:
        """Send ``stop``."""
        self._send(("stop",))


class ViewProcess:
    """The server over ``folders`` on ``host``:``port`` in a child process; ``url`` says where
    (with the token where one is needed); ``sink`` feeds its live scope.

    Parameters
    ----------
    folders : list[Path]
        The folders served.
    host, port
        The address.
    where : str
        The option, named in errors.
    timeout : float, optional
        [s] for the child to start serving.
    loop_cpu : int | None, optional
        The CPU the run's loop is pinned to: the child keeps off it (``step_aside``).

    Raises
    ------
    ConfigError
        If the server did not start, or ended before.
    """

    def __init__(
        self,
        folders: list[Path],
        host: str,
        port: int,
        where: str,
        *,
        timeout: float = 120.0,
        loop_cpu: int | None = None,
    ) -> None:
        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(
            target=serve_child,
            args=(child, [str(f) for f in folders], host, port, where),
            kwargs={"loop_cpu": loop_cpu},
            name="rig-view",
            daemon=True,
        )
        self._proc.start()
        child.close()
        try:
            if not self._conn.poll(timeout):
                raise ConfigError(f"{where}: the view's server did not start within {timeout:g} s")
            kind, text = self._conn.recv()
        except (EOFError, OSError):
            self.close()
            raise ConfigError(f"{where}: the view's server ended before it started") from None
        except ConfigError:
            self.close()
            raise
        if kind != "url":
            self.close()
            raise ConfigError(text)
        self.url: str = text
        self.sink = PipeSink(self._conn)
        self._lock = threading.Lock()

    def finish(self, summary: Mapping[str, Any], grace: float = 2.0) -> None:
        """The run's ``summary`` to every browser (``grace`` s to take it), then the child ends.

        Parameters
        ----------
        summary : Mapping[str, Any]
            The run's summary.
        grace : float, optional
            [s] for browsers to take it.
        """
        if not self.sink.failed:
            try:
                self._conn.send(("finish", dict(summary), grace))
                until = time.monotonic() + grace + 5.0
                while time.monotonic() < until and not self._conn.poll(0.1):
                    pass
            except (OSError, EOFError, ValueError):
                pass
        self.close()

    def close(self) -> None:
        """Close the pipe and wait for the child."""
        try:
            self._conn.close()
        except OSError:
            pass
        self._proc.join(3.0)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(2.0)
