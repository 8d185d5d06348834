"""The Dask client a study runs on (``rig.sweep.engine``), opened and closed.

By default a ``LocalCluster`` with one worker process per core (one thread each: a point is
Python, which a second thread in the same process would only slow down); with a scheduler's
address, that cluster: one started by hand (``dask scheduler``, then ``dask worker ADDRESS
--nthreads 1`` on each machine), by dask-jobqueue (SLURMCluster, PBSCluster, ...) or on
Kubernetes. Each worker imports the toolkit once (``Client.run``) and then runs many points.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
from collections.abc import Callable
from typing import Any

from drivers.errors import ConfigError

__all__ = ["close_client", "cores", "open_client"]

log = logging.getLogger(__name__)


def cores() -> int:
    """The cores this process may run on.

    Returns
    -------
    int
        Cores.
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _warm() -> None:
    """On each worker, once: what a point imports (the session, the emulator, the papers)."""
    import rig.host.session
    import rig.sweep.scenarios  # noqa: F401


class ClosingCommNoise(logging.Filter):
    """Drops what a closing worker logs about the connections its own close cuts.

    A worker's close ends its connection pool while a heartbeat to the scheduler may be in
    flight; distributed then logs "Failed to communicate with scheduler during heartbeat" at
    ERROR with a CommClosedError traceback (distributed 2026.8, ``Worker.heartbeat``). At the end
    of a sweep, or after Ctrl-C, the rows are in and that traceback says nothing. Records carrying
    an OSError are dropped while ``closing()`` is true; everything else is kept.

    Parameters
    ----------
    closing : Callable[[], bool]
        True once the worker of this process has begun to close.
    """

    def __init__(self, closing: Callable[[], bool]) -> None:
        super().__init__("rig.sweep.closing")
        self._closing = closing

    def filter(self, record: logging.LogRecord) -> bool:
        """False for a record with an OSError while the worker closes."""
        error = record.exc_info[1] if record.exc_info else None
        return not (isinstance(error, OSError) and self._closing())


def _hush_closing_comms(dask_worker: Any) -> None:
    """On each local worker as it starts (one its nanny restarts too): ``ClosingCommNoise`` on
    distributed's stderr handlers, closing once ``dask_worker`` has begun to close."""
    from distributed.core import Status

    ending = (Status.closing, Status.closing_gracefully, Status.closed, Status.failed)
    for handler in logging.getLogger("distributed").handlers:
        handler.addFilter(ClosingCommNoise(lambda: dask_worker.status in ending))


def _quiet_on_ctrl_c(start: Callable[[], Any]) -> Any:
    """``start()`` with SIGINT ignored, so the worker processes it spawns inherit that (an ignored
    signal stays ignored across exec, and Python keeps it so): Ctrl-C in the terminal reaches the
    whole process group, and the client alone answers it (it cancels, keeps the rows and closes
    the cluster) instead of each worker printing its KeyboardInterrupt."""
    if threading.current_thread() is not threading.main_thread():
        return start()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        return start()
    finally:
        signal.signal(signal.SIGINT, previous)


#: [s] the wait for a connection to the scheduler at --scheduler (Dask's ``timeout``), and then
#: for its handshake
CONNECT_TIMEOUT = 10.0
HANDSHAKE = 5.0


def _scheduler_client(address: str, seconds: float) -> Any:
    """A Client of the scheduler at ``address``; ConfigError, one line, within about ``seconds``
    where nothing there speaks Dask as a scheduler (``seconds`` for the connection, ``HANDSHAKE``
    more for the handshake). Dask's own connect timeout covers the TCP
    connect, not the handshake after it (distributed pull request 7698): a port held by another
    server (the dashboard's 8787, an HTTP or SSH server) would hang the Client or make it read
    that server's bytes as a frame length; so Dask's ``connect`` is tried first, its handshake
    bounded, and the Client then made (a worker's address is refused by it)."""
    import asyncio

    from dask.distributed import Client
    from distributed.comm.core import connect
    from distributed.security import Security

    async def handshake() -> None:
        args = Security().get_connection_args("client")  # type: ignore[no-untyped-call]
        dialled = connect(address, timeout=seconds, **args)  # type: ignore[no-untyped-call]
        comm = await asyncio.wait_for(dialled, seconds + HANDSHAKE)
        await comm.close()

    hint = (
        "give the address 'dask scheduler' prints (tcp://HOST:8786 by default; 8787 is its dashboard), "
        "or start one with 'dask scheduler' and workers with 'dask worker ADDRESS --nthreads 1'"
    )
    try:
        asyncio.run(handshake())
    except (TimeoutError, asyncio.TimeoutError):
        raise ConfigError(
            f"rig sweep: --scheduler {address}: something accepts connections there but does not answer "
            f"as Dask does (no handshake in {HANDSHAKE:g} s); {hint}"
        ) from None
    except OSError as exc:
        raise ConfigError(
            f"rig sweep: --scheduler {address}: no Dask scheduler answers there ({exc}); {hint}"
        ) from None
    except Exception as exc:  # a malformed address, or a server that is not Dask's
        raise ConfigError(
            f"rig sweep: --scheduler {address}: not a Dask scheduler ({type(exc).__name__}: {exc}); {hint}"
        ) from None
    try:
        return Client(address, timeout=f"{seconds}s")  # type: ignore[no-untyped-call]
    except Exception as exc:  # Dask's, not its scheduler's: a worker's or a nanny's address
        raise ConfigError(
            f"rig sweep: --scheduler {address}: not a Dask scheduler ({type(exc).__name__}: {exc}); {hint}"
        ) from None


def open_client(
    workers: int | None = None, scheduler: str | None = None, *, quiet: bool = True
) -> tuple[Any, dict[str, Any]]:
    """(a dask.distributed Client, the engine's description for sweep.json): a local cluster of
    ``workers`` processes (default: one per core), or the cluster at ``scheduler``. ``quiet``:
    distributed's own loggers (set to INFO when it is imported) say only warnings.

    Parameters
    ----------
    workers : int | None, optional
        Local worker processes (None: one per core).
    scheduler : str | None, optional
        A cluster's scheduler address (None: a local cluster).
    quiet : bool, optional
        distributed's loggers say only warnings.

    Returns
    -------
    tuple[Any, dict[str, Any]]
        (the client, the engine's description).
    """
    from dask.distributed import Client, LocalCluster

    if quiet:
        logging.getLogger("distributed").setLevel(logging.WARNING)

    if scheduler:
        client = _scheduler_client(scheduler, CONNECT_TIMEOUT)
        engine: dict[str, Any] = {"kind": "scheduler", "address": scheduler}
    else:
        n = workers or cores()
        cluster = _quiet_on_ctrl_c(
            lambda: LocalCluster(  # type: ignore[no-untyped-call]
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address="127.0.0.1:0",  # its HTTP server: any free port (8787 may be taken)
                silence_logs=logging.ERROR,
            )
        )
        client = Client(cluster)  # type: ignore[no-untyped-call]
        client.register_worker_callbacks(setup=_hush_closing_comms)  # type: ignore[no-untyped-call]
        engine = {"kind": "local", "address": cluster.scheduler_address}
    from importlib.metadata import version

    client.run(_warm)
    engine |= {"workers": len(client.scheduler_info()["workers"]), "dask": version("dask")}
    return client, engine


#: [s] a stopped sweep's wait for each local worker to end by itself before its nanny ends it
#: (Dask's own is 5 s: a worker in a point's run holds it 4 s)
QUICK_CLOSE = 0.5
#: [s] the same wait at a sweep's end (Dask's default)
CLOSE = 5.0


def close_client(client: Any, *, quick: bool = False) -> None:
    """Close ``client`` and the local cluster it started (if any): the workers first, while their
    scheduler still answers (so a worker's heartbeat meets its own close, which
    ``ClosingCommNoise`` keeps off stderr, never a scheduler gone before it), then the scheduler.
    A worker slow to exit is killed by its nanny, which need not be said (at WARNING) after the
    sweep's rows are in. ``quick`` (a sweep a signal stopped): the local workers are given
    ``QUICK_CLOSE`` to end, then ended (their points are emulated runs, cancelled); else ``CLOSE``.

    Parameters
    ----------
    client : Any
        The client.
    quick : bool, optional
        A signal stopped the sweep: the workers are given ``QUICK_CLOSE`` to end.
    """
    cluster = client.cluster
    client.close()
    if cluster is not None:
        nanny = logging.getLogger("distributed.nanny")
        level = nanny.level
        nanny.setLevel(max(level, logging.ERROR))
        try:
            cluster.sync(_close_workers, cluster, QUICK_CLOSE if quick else CLOSE)
            cluster.close()
        finally:
            nanny.setLevel(level)


async def _close_workers(cluster: Any, timeout: float) -> None:
    """Close each nanny of ``cluster`` and its worker within about ``timeout`` [s]."""
    import asyncio

    await asyncio.gather(*(w.close(timeout=timeout) for w in list(cluster.workers.values())))
