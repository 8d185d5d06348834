"""An emulated CiA 406 rotary encoder on the bus, reading the angle of a ``Shaft``.

Position 0x6004 [increments, 0x6001 per revolution, wrapped to the single-turn
range times 2^16 turns], speed 0x6030:1 [increments/s, Euler backward over the
SYNC period, saturated to INTEGER16]. TPDO1 is sent on its cyclic timer 0x6200
(transmission type 254/255) and TPDO2 on SYNC, as mapped in the EDS. On SYNC the
encoder brings the shaft to the SYNC instant first (``Shaft.sync``), so it reads
the same angle as the drives on the shaft, whichever node handles the frame first.
"""

from __future__ import annotations

import math

import canopen

from drivers.maps import CIA406_EDS
from drivers.maps.cia406 import (
    ENCODER_CYCLIC_TIMER,
    ENCODER_POSITION,
    ENCODER_RESOLUTION,
    ENCODER_SPEED,
)
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.pdo import pack
from plant_emulator.shaft import Shaft

__all__ = ["EmulatedEncoder"]

_TURNS = 1 << 16  #: the multi-turn range [revolutions]


class EmulatedEncoder(EmulatedNode):
    """CiA 406 encoder node on ``shaft``; ``period`` [s] is the SYNC period of its speed.

    Parameters
    ----------
    node_id : int
        Its node.
    network : canopen.Network
        The canopen network it answers on.
    shaft : Shaft
        The shaft it measures.
    period : float
        [s] the SYNC period (its speed's).
    eds : str, optional
        Its EDS.
    """

    def __init__(
        self,
        node_id: int,
        network: canopen.Network,
        shaft: Shaft,
        *,
        period: float,
        eds: str = CIA406_EDS,
    ) -> None:
        super().__init__(node_id, eds, network)
        self.shaft = shaft
        self.period = period
        self._last: int | None = None
        self._last_t = 0.0  #: shaft time [s] of the last latch
        self._speed = 0  #: the last speed [increments/s]

    def on_reset(self, *, application: bool) -> None:
        self._last = None

    def counts(self, ahead: float = 0.0) -> int:
        """The multi-turn count of the shaft angle ``ahead`` [s] after the shaft's time.

        Parameters
        ----------
        ahead : float, optional
            [s] after the shaft's time.

        Returns
        -------
        int
            The multi-turn count.
        """
        per_rev: int = self.od.read(ENCODER_RESOLUTION, 0)
        shaft = self.shaft
        angle = shaft.position + shaft.velocity * ahead if ahead else shaft.position
        return math.floor(angle / (2.0 * math.pi) * per_rev)

    def tick(self, now: float) -> None:
        """Real time: the position object follows the shaft between SYNCs too.

        Parameters
        ----------
        now : float
            [s] the emulator's clock.
        """
        if self.clock_source is not None:
            self.latch()
        super().tick(now)

    def sync_time(self, timestamp: float) -> float:
        return self.shaft.t if self.shaft.lockstep else super().sync_time(timestamp)

    def on_sync_latch(self, timestamp: float) -> None:
        self.shaft.sync(self, timestamp)
        self.latch(ahead=self.shaft.sync_offset)  # sampled at the SYNC (CiA 301)

    def latch(self, *, ahead: float = 0.0) -> None:
        """Position and speed ``ahead`` [s] after the shaft's time (a SYNC); the speed over the
        time since the last latch (a SYNC period in lock-step; the shaft's clock in real time,
        where SYNCs may come late).

        Parameters
        ----------
        ahead : float, optional
            [s] after the shaft's time.
        """
        counts = self.counts(ahead)
        t = self.shaft.t + ahead
        elapsed = self.period if self.shaft.clock is None else t - self._last_t
        if self._last is None or elapsed <= 0.0:
            speed = 0 if self._last is None else self._speed
        else:
            speed = round((counts - self._last) / elapsed)
        self._last, self._last_t, self._speed = counts, t, speed
        od = self.od  # the node's write without its after_write, which the encoder does not override
        od.write(ENCODER_POSITION, 0, counts % (od.read(ENCODER_RESOLUTION, 0) * _TURNS))
        od.write(ENCODER_SPEED, 1, -32768 if speed < -32768 else 32767 if speed > 32767 else speed)

    def event_tpdos(self, now: float) -> None:
        """TPDOs of type 254/255 go out on the cyclic timer 0x6200 [ms] (0: never).

        Parameters
        ----------
        now : float
            [s] the emulator's clock.
        """
        timer = self.od.read(ENCODER_CYCLIC_TIMER, 0)
        if timer and now - self._last_cyclic >= timer / 1000.0 - 1e-9:
            self._last_cyclic = now
            self.write(ENCODER_POSITION, 0, self.counts() % (self.od.read(ENCODER_RESOLUTION, 0) * _TURNS))
            for pdo in self.pdos.tables.event_tpdos:
                self._send(pdo.cob_id, pack(self.od, pdo))

    _last_cyclic = -1e9
