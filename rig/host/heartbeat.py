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
    """See the module docstring; ``beat(k)`` in cycle ``k`` of ``loop_period`` [s]."""

    def __init__(self, network: Any, node_id: int, period: float, loop_period: float) -> None:
        if not 1 <= node_id <= 127:
            raise ValueError(f"the host's node id must be 1..127, got {node_id!r}")
        self.network = network
        self.cob_id = COB_HEARTBEAT + node_id
        self.every = max(1, round(period / loop_period))
        self._data = bytes([NmtState.OPERATIONAL])
        self._slot: int | None = None  #: the ``k // every`` of the last beat

    def beat(self, k: int) -> None:
        """Beat when ``k`` enters a new slot of ``every`` cycles: a real-time loop that skipped
        cycles (``k`` jumped over a multiple) still beats, and a count that starts again (the
        stop's cycles after the loop's) beats at once."""
        slot = k // self.every
        if slot != self._slot:
            self._slot = slot
            self.network.send_message(self.cob_id, self._data)
