"""The host's heartbeat (CiA 301), which the drives watch to stop themselves if the host dies.

Sent by the host loop, once every ``period`` [s] of loop time (a whole number of cycles), so
it stops when the loop stops or hangs, not only when the process dies: a drive whose
consumer (0x1016) misses it takes the reaction of its 0x6007. Its state byte says
OPERATIONAL.
"""

from __future__ import annotations

import logging
from typing import Any

from drivers.maps.cia import COB_HEARTBEAT, NmtState

__all__ = ["HostHeartbeat"]

log = logging.getLogger(__name__)


class HostHeartbeat:
    """The host's heartbeat (module docstring); ``beat(k)`` in cycle ``k``.

    Parameters
    ----------
    network : Any
        The CANopen network it is sent on.
    node_id : int
        The host's node id (1..127).
    period : float
        The heartbeat's period [s] (rounded to a whole number of cycles).
    loop_period : float
        The loop's period [s].

    Raises
    ------
    ValueError
        If ``node_id`` is not 1..127.
    """

    def __init__(self, network: Any, node_id: int, period: float, loop_period: float) -> None:
        if not 1 <= node_id <= 127:
            raise ValueError(f"the host's node id must be 1..127, got {node_id!r}")
        self.network = network
        self.cob_id = COB_HEARTBEAT + node_id
        self.every = max(1, round(period / loop_period))
        self._data = bytes([NmtState.OPERATIONAL])
        self._slot: int | None = None  #: the ``k // every`` of the last beat

    def beat(self, k: int) -> None:
        """Beat when ``k`` enters a new slot of ``every`` cycles.

        A real-time loop that skipped cycles (``k`` jumped over a multiple) still beats, and a count
        that starts again (the stop's cycles after the loop's) beats at once.

        Parameters
        ----------
        k : int
            The cycle's index.
        """
        slot = k // self.every
        if slot != self._slot:
            self._slot = slot
            self.network.send_message(self.cob_id, self._data)
