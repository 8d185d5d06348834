"""Real time asked of the operating system, and a record of what it granted.

The shape of ros2_control's ``ros2_control_node`` (``thread_priority``, ``cpu_affinity``,
``lock_memory``) and the ROS 2 real-time cookbook: each measure small and separate, asked for
before the loop starts, refused ones reported once and the run goes on.

- ``SCHED_FIFO`` at ``priority`` for the thread that keeps the period (the host loop, or the
  emulator's clock), and one above it for the threads that carry its frames (the bus's receive
  thread: a frame never waits behind the loop it feeds). A thread at real-time priority must
  sleep between its cycles: none here spins (docs/architecture.md, "One cycle").
- pinned to one CPU (``cpu``: -1 the last one the process may use, -2 not pinned), so the
  loop's caches and the handoffs between its threads stay on one core;
- memory locked (``mlockall``, on fault: the pages the process uses stay in memory, and each
  new one is locked as it is first touched; the libraries' untouched pages are not read in:
  docs/time.md says what that saves);
- a timer slack of 1 ns where the policy stays normal (real-time threads have none);
- the CPU kept awake: a PM QoS CPU latency request (``cpu_latency`` [us], 0 by default) on
  ``/dev/cpu_dma_latency``, held open for the run and released with it, as cyclictest holds it.
  The kernel then keeps every CPU out of the idle states that take longer to leave: on a virtual
  machine whose idle vCPU halts (cpuidle's haltpoll with guest halt polling off), each wake-up
  otherwise costs a VM exit (docs/time.md has the figure); the value in force after the request
  is recorded.

``request(...)`` asks for them, returns a ``Grant`` (its ``record()`` goes into the summary), and
``Grant.release()`` gives back what was taken (the process may go on: a benchmark, a test).
Linux only; elsewhere every measure is refused and said so.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import functools
import gc
import logging
import os
import struct
import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "YOUNG",
    "Grant",
    "RealtimeRequest",
    "collect_young",
    "cpu_stolen",
    "loop_cpu",
    "receive_threads",
    "request",
]

log = logging.getLogger(__name__)

_MCL_CURRENT, _MCL_FUTURE, _MCL_ONFAULT = 1, 2, 4
YOUNG = 700  #: young objects before a collection in the slack (CPython's own first threshold)
_PR_SET_TIMERSLACK = 29
CPU_DMA_LATENCY = "/dev/cpu_dma_latency"  #: the kernel's PM QoS CPU latency request
_LAST, _UNPINNED = -1, -2


@dataclass(frozen=True)
class RealtimeRequest:
    """What to ask for (module docstring)."""

    priority: int = 50  #: SCHED_FIFO 1-99 (0: the normal policy)
    cpu: int = _LAST  #: the CPU to pin to (-1: the last the process may use; -2: not pinned)
    lock_memory: bool = True  #: ``mlockall``
    cpu_latency: int = 0  #: [us] the PM QoS CPU latency held for the run (-1: none asked)


@functools.cache
def _libc() -> Any:
    """The C library (for mlockall and prctl), found once; None where there is none."""
    name = ctypes.util.find_library("c")
    return ctypes.CDLL(name, use_errno=True) if name else None


def loop_cpu(wanted: int) -> int | None:
    """The CPU ``request`` pins the loop to for ``RealtimeRequest.cpu`` = ``wanted``.

    Parameters
    ----------
    wanted : int
        A CPU, -1 (the last the process may use) or -2 (not pinned).

    Returns
    -------
    int | None
        The CPU; None: not pinned, or no affinity on this system.
    """
    if wanted == _UNPINNED or not hasattr(os, "sched_getaffinity"):
        return None
    allowed = sorted(os.sched_getaffinity(0))
    return allowed[-1] if wanted == _LAST else wanted


@dataclass
class _Thread:
    """One thread's scheduling before we changed it (restored by ``release``)."""

    tid: int
    policy: int
    param: Any
    affinity: set[int] | None


@dataclass
class Grant:
    """What was granted; ``refused`` says what was not, each with the system's reason."""

    asked: RealtimeRequest  #: what was asked for
    priority: int = 0  #: SCHED_FIFO priority of the loop thread (0: not granted)
    receive_priority: int = 0  #: of the receive threads (0: none, or not granted)
    receive_threads: int = 0  #: how many were raised
    cpu: int | None = None  #: pinned to (None: not)
    memory_locked: bool = False  #: ``mlockall`` in force
    #: [us] the PM QoS CPU latency held (None: none asked, or refused); and the one in force
    cpu_latency: int | None = None
    cpu_latency_in_force: int | None = None  #: [us] (None: not read)
    refused: list[str] = field(default_factory=list)  #: what was not, each with the system's reason
    _saved: list[_Thread] = field(default_factory=list)  #: the threads changed, as they were
    _locked_here: bool = False  #: ``release`` unlocks the memory
    _qos: int | None = None  #: the open /dev/cpu_dma_latency (the request lasts while it is open)

    @property
    def fifo(self) -> bool:
        """The loop thread got SCHED_FIFO."""
        return self.priority > 0

    def record(self) -> dict[str, Any]:
        """The summary's ``realtime``: policy, priorities, CPU, memory lock, what was refused.

        Returns
        -------
        dict[str, Any]
            summary.json's keys (docs/files.md).
        """
        return {
            "policy": "SCHED_FIFO" if self.fifo else "SCHED_OTHER",
            "priority": self.priority,
            "receive_priority": self.receive_priority,
            "receive_threads": self.receive_threads,
            "cpu": self.cpu,
            "memory_locked": self.memory_locked,
            "cpu_latency_us": self.cpu_latency,
            "cpu_latency_in_force_us": self.cpu_latency_in_force,
            "refused": list(self.refused),
        }

    def describe(self) -> str:
        """One line: what the run was granted.

        Returns
        -------
        str
            Scheduling, CPU, memory and CPU latency, in words.
        """
        policy = f"SCHED_FIFO {self.priority}" if self.fifo else "normal scheduling"
        if self.receive_priority:
            policy += f" (receive {self.receive_priority})"
        where = f"CPU {self.cpu}" if self.cpu is not None else "not pinned"
        memory = "memory locked" if self.memory_locked else "memory not locked"
        awake = (
            f"CPU latency held at {self.cpu_latency} us" if self.cpu_latency is not None else "CPU may sleep"
        )
        return f"{policy}, {where}, {memory}, {awake}"

    def keep(self, tid: int) -> None:
        """Thread ``tid``'s scheduling and CPUs as they are now, restored by ``release``.

        Parameters
        ----------
        tid : int
            A thread of this process (its native id).
        """
        self._saved.append(
            _Thread(tid, os.sched_getscheduler(tid), os.sched_getparam(tid), os.sched_getaffinity(tid))
        )

    def release(self) -> None:
        """Every thread back to its scheduling and CPUs; memory unlocked if locked here."""
        for saved in reversed(self._saved):
            with contextlib.suppress(OSError):  # the thread may have ended
                if saved.affinity is not None:
                    os.sched_setaffinity(saved.tid, saved.affinity)
                os.sched_setscheduler(saved.tid, saved.policy, saved.param)
        self._saved.clear()
        if self._qos is not None:
            with contextlib.suppress(OSError):
                os.close(self._qos)  # the kernel drops the request with its file
            self._qos = None
        if self._locked_here:
            libc = _libc()
            if libc is not None:
                libc.munlockall()
            self._locked_here = False


def _raise(grant: Grant, tid: int, priority: int, what: str) -> bool:
    """``tid`` to SCHED_FIFO ``priority`` and ``grant.cpu``; its old scheduling kept. False
    (and a refusal noted) when the system refuses."""
    try:
        saved = _Thread(
            tid,
            os.sched_getscheduler(tid),
            os.sched_getparam(tid),
            os.sched_getaffinity(tid) if grant.cpu is not None else None,
        )
    except (OSError, AttributeError) as exc:
        grant.refused.append(f"{what}: {exc}")
        return False
    grant._saved.append(saved)
    ok = True
    if priority > 0:
        try:
            os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(priority))
        except OSError as exc:
            grant.refused.append(f"SCHED_FIFO {priority} for {what}: {exc.strerror or exc}")
            ok = False
    if grant.cpu is not None:
        try:
            os.sched_setaffinity(tid, {grant.cpu})
        except (OSError, ValueError) as exc:
            grant.refused.append(f"CPU {grant.cpu} for {what}: {exc}")
            grant.cpu = None
    return ok


def _slack() -> None:
    """A 1 ns timer slack for the calling thread (its sleeps end on time without SCHED_FIFO)."""
    libc = _libc()
    if libc is not None:
        libc.prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0)


def _lock(grant: Grant) -> None:
    libc = _libc()
    if libc is None or not hasattr(libc, "mlockall"):
        grant.refused.append("memory lock: no mlockall on this system")
        return
    if libc.mlockall(_MCL_CURRENT | _MCL_FUTURE | _MCL_ONFAULT) != 0 and (
        ctypes.get_errno() != errno.EINVAL
        or libc.mlockall(_MCL_CURRENT | _MCL_FUTURE) != 0  # before Linux 4.4
    ):
        err = ctypes.get_errno()
        grant.refused.append(f"memory lock: {os.strerror(err)}")
        return
    grant.memory_locked = grant._locked_here = True


def _keep_awake(grant: Grant, latency: int, path: str = CPU_DMA_LATENCY) -> None:
    """Hold a PM QoS CPU latency request of ``latency`` [us] (``path`` open, the value written as
    a binary 32-bit integer, as the kernel's PM QoS interface takes it); the value in force read
    back."""
    try:
        fd = os.open(path, os.O_RDWR)
    except OSError as exc:
        grant.refused.append(f"PM QoS CPU latency {latency} us ({path}): {exc.strerror or exc}")
        return
    try:
        os.write(fd, struct.pack("=i", latency))
        data = os.pread(fd, 4, 0) if hasattr(os, "pread") else b""
    except OSError as exc:
        os.close(fd)
        grant.refused.append(f"PM QoS CPU latency {latency} us ({path}): {exc.strerror or exc}")
        return
    grant._qos, grant.cpu_latency = fd, latency
    grant.cpu_latency_in_force = struct.unpack("=i", data)[0] if len(data) == 4 else None


def request(ask: RealtimeRequest, receive: Sequence[threading.Thread] = ()) -> Grant:
    """Ask for ``ask`` for the calling thread and, one priority above it, for the ``receive`` threads.

    One warning lists what was refused. Call ``release()`` on the result at the end.

    Parameters
    ----------
    ask : RealtimeRequest
        What to ask for.
    receive : Sequence[threading.Thread]
        The threads that carry the loop's frames (`receive_threads`).

    Returns
    -------
    Grant
        What was granted and refused.
    """
    grant = Grant(ask, cpu=loop_cpu(ask.cpu))
    if not hasattr(os, "sched_setscheduler"):
        grant.refused.append(f"real-time scheduling: not available on {os.name}")
        grant.cpu = None
    else:
        tid = threading.get_native_id()
        if _raise(grant, tid, ask.priority, "the loop thread") and ask.priority > 0:
            grant.priority = ask.priority
        high = min(ask.priority + 1, 99) if ask.priority > 0 else 0
        raised = 0
        for thread in receive:
            if thread.native_id is not None and _raise(grant, thread.native_id, high, f"{thread.name!r}"):
                raised += 1
        if raised and high:
            grant.receive_priority, grant.receive_threads = high, raised
    if not grant.fifo:
        _slack()
    if ask.lock_memory:
        _lock(grant)
    if ask.cpu_latency >= 0:
        _keep_awake(grant, ask.cpu_latency)
    if grant.refused:
        log.warning("real time not fully granted (%s): %s", grant.describe(), "; ".join(grant.refused))
    return grant


def collect_young(threshold: int = YOUNG) -> bool:
    """The young generations collected once ``threshold`` objects wait, the collector being disabled.

    For real time the heap is frozen before and the collector disabled; a thread calls this in its
    slack, so no collection runs in a cycle's work (the middle generation too every tenth time).

    Parameters
    ----------
    threshold : int
        Young objects before a collection.

    Returns
    -------
    bool
        True if one ran.
    """
    young, middle, _ = gc.get_count()
    if young < threshold:
        return False
    gc.collect(1 if middle >= 10 else 0)
    return True


def receive_threads(network: Any) -> list[threading.Thread]:
    """The receive threads of a canopen ``network``'s python-can notifier (none in process).

    Parameters
    ----------
    network : Any
        A canopen network.

    Returns
    -------
    list[threading.Thread]
        The live ones.
    """
    notifier = getattr(network, "notifier", None)
    readers = getattr(notifier, "_readers", ())
    return [t for t in readers if isinstance(t, threading.Thread) and t.is_alive()]


def cpu_stolen(stat: str = "/proc/stat") -> float | None:
    """CPU time a hypervisor has taken from this machine's CPUs since boot (steal time).

    Summed over them: time a virtual CPU had work and its host ran something else, when no priority
    inside the machine helps; from /proc/stat in the kernel's ticks (10 ms steps where USER_HZ is
    100).

    Parameters
    ----------
    stat : str
        The file read.

    Returns
    -------
    float | None
        [s]; None where the system does not say (not Linux, a kernel before 2.6.11).
    """
    try:
        with open(stat, encoding="ascii") as f:
            fields = f.readline().split()
        return int(fields[8]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None
