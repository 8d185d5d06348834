"""A viewer's thread beside a real-time loop in the same interpreter (``rig.live.view.LiveView``).

While such a thread holds the interpreter lock the loop may wait for it. At normal priority any
process of the machine (a browser, a build) may take its CPU just then, and the loop waits for
that process's time slice as well: on a loaded machine, a draw of 0.2 ms of CPU took up to 10 ms
(``rig bench view``). At the lowest real-time priority, on the CPUs other than the loop's,
nothing of normal priority preempts it, and it never delays a real-time thread; its work is
short and it sleeps between (the loop's slack: ``rig.live.view.Ring``).
"""

from __future__ import annotations

import logging
import os
import threading

from rig.host.realtime import Grant

__all__ = ["VIEWER_PRIORITY", "raise_viewer"]

log = logging.getLogger(__name__)

VIEWER_PRIORITY = 1  #: SCHED_FIFO of the viewer: the lowest


def raise_viewer(grant: Grant, thread: threading.Thread) -> bool:
    """``thread`` at SCHED_FIFO ``VIEWER_PRIORITY`` on the CPUs other than the loop's, where the loop
    is at real-time priority (``grant.fifo``); ``grant.release()`` restores it.

    Parameters
    ----------
    grant : Grant
        The loop's (``rig.host.realtime.request``).
    thread : threading.Thread
        The viewer, started.

    Returns
    -------
    bool
        Raised (False: the loop is not at real-time priority, the thread has ended, or the system
        refused).
    """
    tid = thread.native_id
    if not grant.fifo or tid is None or not thread.is_alive():
        return False
    try:
        grant.keep(tid)
        os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(VIEWER_PRIORITY))
        others = os.sched_getaffinity(tid) - {grant.cpu}
        if grant.cpu is not None and others:
            os.sched_setaffinity(tid, others)
    except OSError as exc:
        log.debug("the viewer %r stays at its priority: %s", thread.name, exc)
        return False
    return True
