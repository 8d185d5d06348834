"""Host-side CiA 406 rotary encoder driver over canopen.

Position 0x6004 [increments] and speed 0x6030:1 [increments/s] from TPDO2
(on SYNC), converted with the encoder's own 0x6001 (increments per revolution).
"""

from __future__ import annotations

import math
from typing import Any

import canopen
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from drivers.errors import CommunicationTimeout, ConfigError, SdoAbort
from drivers.maps import CIA406_EDS
from drivers.maps.od import load_od

__all__ = ["Cia406Encoder"]


class Cia406Encoder:
    """A CiA 406 encoder at ``node_id``; ``read()`` gives (angle [rad], speed [rad/s])."""

    def __init__(
        self, network: canopen.Network, node_id: int, *, eds: str = CIA406_EDS, sdo_timeout: float = 0.3
    ):
        self.node_id = node_id
        self.node: Any = canopen.RemoteNode(node_id, load_od(eds, node_id))
        self.node.sdo.RESPONSE_TIMEOUT = sdo_timeout
        network.add_node(self.node)
        self.counts_per_rad = math.nan
        self._turns = 0
        self._last_raw: int | None = None

    def connect(self) -> None:
        """Check the device type, read the resolution and the PDO mapping."""
        try:
            device_type = self.node.sdo[0x1000].raw
            per_rev = self.node.sdo[0x6001].raw
            self.node.tpdo.read()
        except SdoAbortedError as exc:
            raise SdoAbort(
                "encoder setup", code=exc.code, node_id=self.node_id, index=0x6001, subindex=0
            ) from exc
        except SdoCommunicationError as exc:
            raise CommunicationTimeout(f"encoder node {self.node_id}: no SDO answer") from exc
        if device_type & 0xFFFF != 406:
            raise ConfigError(f"node {self.node_id} is not a CiA 406 encoder (0x1000 = 0x{device_type:08X})")
        self.counts_per_rad = per_rev / (2.0 * math.pi)
        self.modulus = per_rev << 16
        self._pos = self.node.tpdo[2]["Position value"]
        self._speed = self.node.tpdo[2]["Speed value.Speed value channel 1"]

    def read(self) -> tuple[float, float]:
        """(angle [rad], speed [rad/s]) from the last TPDO2, the angle unwrapped over the 2^16-turn range."""
        raw = int(self._pos.raw)
        if self._last_raw is not None:
            step = raw - self._last_raw
            if step > self.modulus // 2:
                self._turns -= 1
            elif step < -self.modulus // 2:
                self._turns += 1
        self._last_raw = raw
        counts = raw + self._turns * self.modulus
        return counts / self.counts_per_rad, self._speed.raw / self.counts_per_rad
