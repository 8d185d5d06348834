"""The loop thread reading a CAN bus itself, in place of python-can's receive thread.

On a bus that lets one thread claim its reading (``claim``/``release``, with ``fill``: the
socketcand client's, ``drivers.socketcand_client``), ``OwnedReceive`` reads the frames and hands
each to the canopen network's listeners as python-can's notifier would: the host's pacing
(``rig.host.pacing.HostSync.owning``) wakes on a SYNC's answer itself, not after a receive thread
has read it and woken it, two thread switches less per cycle (docs/time.md).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

__all__ = ["OwnedReceive"]


class OwnedReceive:
    """The calling thread reads ``network``'s bus itself (``claim``) and hands each frame to the
    network's listeners, in order, as python-can's notifier thread would (which parks meanwhile);
    ``release`` gives the reading back. A receive error raises in the reading thread (the loop's
    safe stop names a lost bus).

    Parameters
    ----------
    network : canopen.Network
        The connected network whose bus is read (``possible`` says whether it can be).
    """

    def __init__(self, network: Any) -> None:
        self.bus = network.bus
        self.listeners = network.notifier.listeners

    @staticmethod
    def possible(network: Any) -> bool:
        """Whether ``network``'s bus lets a thread claim its reading (socketcand's does).

        Parameters
        ----------
        network : canopen.Network
            The network asked about.

        Returns
        -------
        bool
            Its bus has ``claim`` and ``fill``, and a notifier hands frames to its listeners.
        """
        bus = getattr(network, "bus", None)
        return (
            callable(getattr(bus, "claim", None))
            and callable(getattr(bus, "fill", None))
            and network.notifier is not None
        )

    def claim(self, others: bool) -> None:
        """The calling thread reads the bus from now on (python-can's notifier parks).

        Parameters
        ----------
        others : bool
            Another thread (the notifier's) reads the bus now: the claim waits for it to park.
        """
        self.bus.claim(others=others)

    def release(self) -> None:
        """The reading given back to the notifier's thread."""
        self.bus.release()

    def arrived(self) -> None:
        """Every frame that has come, handed on; none waited for."""
        self.until(lambda: True, 0.0)

    def until(self, done: Callable[[], bool], timeout: float) -> bool:
        """Frames read and handed on until ``done()`` or ``timeout`` [s], then every frame that
        has come by then (not waited for; the bus's ``fill``: one read of the socket, so a
        flood cannot hold the loop here): after a stall, a node's burst of answers to the
        SYNCs it owed is read at once, and the newest sample counts, as with a receive thread
        (read only up to ``done()``, the rest of a burst stayed queued, and every later cycle
        acted on a sample that many periods old).

        Parameters
        ----------
        done : callable
            Says, without arguments, that what was awaited has come.
        timeout : float
            How long to wait for it [s].

        Returns
        -------
        bool
            ``done()`` came true before ``timeout``.
        """
        deadline = time.perf_counter() + timeout
        recv, listeners = self.bus.recv, self.listeners
        while not done():
            left = deadline - time.perf_counter()
            if left < 0.0:
                return False
            msg = recv(left)
            if msg is not None:
                for listener in listeners:
                    listener(msg)
        # what has come by now, and no more: a sender that never pauses (another client's flood)
        # held a drain until nothing more came for ever (no SYNC, no RPDO: the drive's deadline)
        for _ in range(self.bus.fill()):
            msg = recv(0.0)
            if msg is not None:
                for listener in listeners:
                    listener(msg)
        return True
