"""Host-side CiA 406 rotary encoder: a feedback-only ``AxisDriver`` on canopen.

Position 0x6004 [increments] from the TPDO that carries it on SYNC (read from
the mapping in force), converted with the encoder's own 0x6001 (measuring
units per revolution) and unwrapped over its multi-turn range. Speed is the
encoder's 0x6030:1 [increments/s] where that TPDO maps it; with
``speed_from_position`` (or where it is not mapped) it is the backward
difference of the position over the time between the two samples (whole SYNC
periods in lock-step, the frames' stamps in real time), since 0x6030 is an
INTEGER16 and saturates at 32,767 increments/s (8 revolutions/s at 4096 counts).
"""

from __future__ import annotations

import math

import canopen

from drivers.base import AxisState, Feedback
from drivers.canopen_axis import CanopenAxis, TpdoSlot, sample_interval
from drivers.errors import ConfigError
from drivers.maps import CIA406_EDS, cia, cia406

__all__ = ["Cia406Axis"]


class Cia406Axis(CanopenAxis):
    """A CiA 406 encoder at ``node_id``; ``period`` [s] is the SYNC period (for the speed by difference).

    Parameters
    ----------
    name : str
        The axis's name.
    network : canopen.Network
        The canopen network.
    node_id : int
        The encoder's node.
    period : float
        [s] the SYNC period, > 0.
    eds : str | None, optional
        Its EDS/DCF (None: the toolkit's generic one).
    speed_from_position : bool, optional
        The speed by difference of positions, not the device's 0x6030.
    heartbeat_timeout : float, optional
        [s] 0: no heartbeat supervised.

    Raises
    ------
    ConfigError
        If ``period`` <= 0.
    """

    measures = frozenset({"position", "velocity"})

    def __init__(
        self,
        name: str,
        network: canopen.Network,
        node_id: int,
        *,
        period: float,
        eds: str | None = None,
        speed_from_position: bool = False,
        heartbeat_timeout: float = 0.0,
    ) -> None:
        super().__init__(
            name,
            None,
            network,
            node_id,
            eds=eds or CIA406_EDS,
            eds_given=eds is not None,
            heartbeat_timeout=heartbeat_timeout,
        )
        if not period > 0.0:
            raise ConfigError(f"axis {name!r}: the SYNC period must be > 0 s, got {period!r}")
        self.period = period
        self.speed_from_position = speed_from_position
        self.counts_per_rad = math.nan
        self._turns = 0
        self._last_raw: int | None = None
        self._last_counts: int | None = None
        self._last_stamp: float | None = None
        self._last: Feedback | None = None

    def setup(self) -> None:
        """Check the device type and identity (``check_identity``), read the resolution and the
        TPDO carrying the position on SYNC.

        Raises
        ------
        ConfigError
            If it is no CiA 406 encoder, its resolution is 0, or no synchronous TPDO maps the position.
        """
        device_type = self.sdo_read(cia.DEVICE_TYPE)
        if device_type & 0xFFFF != cia.PROFILE_ENCODER:
            raise ConfigError(f"node {self.node_id} is not a CiA 406 encoder (0x1000 = 0x{device_type:08X})")
        self.device_id = self.check_identity(give=self.eds_hint)
        per_rev = self.sdo_read(cia406.ENCODER_RESOLUTION)
        if not per_rev:
            raise ConfigError(f"node {self.node_id}: 0x6001 measuring units per revolution is 0")
        self.counts_per_rad = per_rev / (2.0 * math.pi)
        self.modulus = per_rev << 16
        try:
            self.node.tpdo.read()
        except Exception as exc:  # canopen raises SDO errors while reading the maps
            raise ConfigError(f"node {self.node_id}: cannot read the TPDO mapping: {exc}") from exc
        self.nmt("OPERATIONAL")
        for pdo in self.node.tpdo.values():
            entries = [(v.index, v.subindex) for v in pdo.map]
            if (
                pdo.enabled
                and 1 <= (pdo.trans_type or 0) <= cia.PDO_SYNC_MAX
                and ((cia406.ENCODER_POSITION, 0) in entries)
            ):
                self._slot: TpdoSlot = self.tpdos.receive(pdo)
                self._position_at = entries.index((cia406.ENCODER_POSITION, 0))
                speed = (cia406.ENCODER_SPEED, 1)
                self._speed_at = entries.index(speed) if speed in entries else None
                return
        raise ConfigError(f"node {self.node_id}: no synchronous TPDO maps the position 0x6004")

    def _elapsed(self, last: float | None, stamp: float | None) -> float:
        """[s] from the sample stamped ``last`` to this one (``stamp``): ``sample_interval``."""
        return sample_interval(last, stamp, self.period)

    def quanta(self) -> tuple[float, float]:
        """One count [rad] (0x6001) and the speed one count makes over a period [rad/s].

        Returns
        -------
        tuple[float, float]
            (one count [rad], one count per period [rad/s]).
        """
        if not (math.isfinite(self.counts_per_rad) and self.counts_per_rad > 0.0):
            return (0.0, 0.0)
        q = 1.0 / self.counts_per_rad
        return (q, q / self.period)

    def enable(self, *, timeout: float = 1.0) -> None:
        """An encoder has nothing to enable.

        Parameters
        ----------
        timeout : float, optional
            Unused.
        """

    def disable(self) -> None:
        """An encoder has nothing to disable."""

    def quick_stop(self) -> None:
        """An encoder has nothing to stop."""

    def read_state(self) -> AxisState:
        """ENABLED where the node is OPERATIONAL, else DISABLED.

        Returns
        -------
        AxisState
            The axis's state.
        """
        return AxisState.ENABLED if self.nmt_state == "OPERATIONAL" else AxisState.DISABLED

    def feedback(self) -> Feedback:
        """(angle [rad], speed [rad/s]) from the last TPDO, the angle unwrapped.

        Returns
        -------
        Feedback
            (angle [rad], speed [rad/s]).
        """
        slot = self._slot
        if slot.timestamp == self._last_stamp and self._last is not None:
            return self._last  # no new sample: the same one (the watchdog counts it)
        previous, self._last_stamp = self._last_stamp, slot.timestamp
        values = slot.values()
        raw = int(values[self._position_at])
        if self._last_raw is not None:
            step = raw - self._last_raw
            if step > self.modulus // 2:
                self._turns -= 1
            elif step < -self.modulus // 2:
                self._turns += 1
        self._last_raw = raw
        counts = raw + self._turns * self.modulus
        if self._speed_at is not None and not self.speed_from_position:
            speed = values[self._speed_at] / self.counts_per_rad
        else:
            last = self._last_counts
            elapsed = self._elapsed(previous, slot.timestamp)
            speed = 0.0 if last is None else (counts - last) / elapsed / self.counts_per_rad
        self._last_counts = counts
        self._last = Feedback(counts / self.counts_per_rad, speed, stamp=slot.timestamp)
        return self._last
