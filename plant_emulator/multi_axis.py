"""An emulated drive of several axes on one node: one CANopen node, a CiA 402 drive per axis.

CiA 301 and CiA 402 lay such a module out as logical devices (``drivers.maps.logical``): the
node's communication (NMT, SDO, PDOs, SYNC, EMCY, heartbeat producer and consumer) is one, and
each axis has its own objects 0x800 (n - 1) above axis 1's, its own state machine, modes, units,
limits and stops, and its own motor. ``MultiAxisDrive`` is the node and axis 1 (an
``EmulatedDrive``); each further axis is a ``LogicalDrive``: an ``EmulatedDrive`` on the same
node whose objects are read and written through ``AxisStore`` (its profile objects at axis 1's
indices, so every part of the drive runs unchanged on them), with a shaft and motor of its own.

The node routes to each axis what is its: a write to an object (SDO or RPDO) to the axis whose
range it is in; an RPDO to the axes whose objects it maps; each SYNC, reset and loss of the
host (each axis reacts by its own 0x6007) to every axis. An EMCY is the node's: it names no axis
(CiA 301), and 0x1001 is one for the node; each axis keeps its own 0x603F.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import canopen

from drivers.maps.logical import axis_dictionary, axis_object, object_axis
from plant_emulator.axes import Axis
from plant_emulator.cia402_drive import EmulatedDrive, Ratings
from plant_emulator.device_profile import DeviceProfile
from plant_emulator.od_store import ObjectStore
from plant_emulator.shaft import Shaft

__all__ = ["AxisStore", "LogicalDrive", "MultiAxisDrive"]


class AxisStore:
    """``store`` as axis ``axis`` sees it: its profile objects at axis 1's indices, the node's
    objects as they are (``ObjectStore``'s device-side access).

    Parameters
    ----------
    store : ObjectStore
        The node's object store.
    axis : int
        The axis, 1..8.
    """

    def __init__(self, store: ObjectStore, axis: int) -> None:
        self.store, self.axis = store, axis

    def read(self, index: int, subindex: int = 0) -> Any:
        """The value of (index, subindex) as the axis names it (``ObjectStore.read``).

        Parameters
        ----------
        index, subindex : int
            The object, as axis 1's.

        Returns
        -------
        Any
            Its value.
        """
        return self.store.read(axis_object(index, self.axis), subindex)

    def write(self, index: int, subindex: int, value: Any) -> None:
        """Set (index, subindex) as the axis names it (``ObjectStore.write``).

        Parameters
        ----------
        index, subindex : int
            The object, as axis 1's.
        value : Any
            Its value.
        """
        self.store.write(axis_object(index, self.axis), subindex, value)

    def has(self, index: int, subindex: int = 0) -> bool:
        """Whether the node has (index, subindex) as the axis names it.

        Parameters
        ----------
        index, subindex : int
            The object, as axis 1's.

        Returns
        -------
        bool
            It has.
        """
        return self.store.has(axis_object(index, self.axis), subindex)

    def obj(self, index: int, subindex: int) -> Any:
        """The OD entry of (index, subindex) as the axis names it (``ObjectStore.obj``).

        Parameters
        ----------
        index, subindex : int
            The object, as axis 1's.

        Returns
        -------
        Any
            canopen's ``ODVariable``.
        """
        return self.store.obj(axis_object(index, self.axis), subindex)


class LogicalDrive(EmulatedDrive):
    """Axis ``number`` (2..8) of ``node``'s drive, with ``axis`` behind it on ``shaft``; see the
    module docstring. Its node's work (SYNC, PDOs, supervision) is the node's: it is given the
    events that are its own.

    Parameters
    ----------
    node : MultiAxisDrive
        The node whose axis it is.
    number : int
        The axis, 2..8.
    axis : Axis
        Its physics.
    shaft : Shaft | None
        The shaft it is part of (None: one of its own).
    """

    def __init__(self, node: MultiAxisDrive, number: int, axis: Axis, shaft: Shaft | None) -> None:
        self._own(axis, node.period, node.profile, shaft)
        self.number = number
        self.host = node
        self.node_id, self.network, self.node = node.node_id, node.network, node.node
        self.od: Any = AxisStore(node.od, number)
        source = str(self.profile.eds)
        self._objects(axis_dictionary(node.node.object_dictionary, number, source=source))

    @property
    def in_rpdo(self) -> bool:  # type: ignore[override]
        return self.host.in_rpdo

    @property
    def rx_time(self) -> float:  # type: ignore[override]
        return self.host.rx_time

    @property
    def clock(self) -> float:  # type: ignore[override]
        return self.host.clock

    @property
    def clock_source(self) -> Any:  # type: ignore[override]
        return self.host.clock_source

    def supervise(self, now: float) -> None:
        """The node's watch of the host is its node's (``MultiAxisDrive``'s): a loss reaches this
        axis as ``on_abort_connection``.

        Parameters
        ----------
        now : float
            [s] the emulator's clock.
        """


class MultiAxisDrive(EmulatedDrive):
    """The node of a drive of ``len(axes)`` axes, and its axis 1; ``shafts``: the plant each
    axis is part of (None: each a shaft of its own). See the module docstring.

    Parameters
    ----------
    node_id : int
        Its node.
    network : canopen.Network
        The canopen network.
    axes : Sequence[Axis]
        Each axis's physics, axis 1 first.
    period : float
        [s] the SYNC period.
    profile : DeviceProfile
        The device's profile (its twin).
    shafts : Sequence[Shaft | None] | None, optional
        The shaft of each axis (None: each its own).
    """

    def __init__(
        self,
        node_id: int,
        network: canopen.Network,
        axes: Sequence[Axis],
        *,
        period: float,
        profile: DeviceProfile,
        shafts: Sequence[Shaft | None] | None = None,
    ) -> None:
        places = list(shafts) if shafts is not None else [None] * len(axes)
        super().__init__(node_id, network, axes[0], period=period, profile=profile, shaft=places[0])
        self.others = [
            LogicalDrive(self, n, axis, shaft) for n, (axis, shaft) in enumerate(zip(axes[1:], places[1:]), 2)
        ]

    @property
    def drives(self) -> list[EmulatedDrive]:
        """Axis 1, 2, ... of the drive."""
        return [self, *self.others]

    @property
    def shafts(self) -> list[Shaft]:
        """Each axis's plant."""
        return [d.shaft for d in self.drives]

    @property
    def lockstep(self) -> bool:
        """Every axis's shaft keeps the same time (``EmulatedDrive.lockstep``)."""
        return self.shaft.lockstep

    @lockstep.setter
    def lockstep(self, value: bool) -> None:
        for shaft in self.shafts:
            shaft.lockstep = value

    @property
    def enabled(self) -> bool:
        """An axis of the drive has its motor (``EmulatedDrive.enabled``)."""
        return any(EmulatedDrive.enabled.fget(d) for d in self.drives)  # type: ignore[attr-defined]

    def rate(self, ratings: Ratings, *, counts_per_rev: int | None) -> None:
        super().rate(ratings, counts_per_rev=counts_per_rev)
        for d in self.others:
            d.rate(ratings, counts_per_rev=counts_per_rev)

    def _routed(self, index: int) -> tuple[EmulatedDrive, int]:
        """The axis whose object ``index`` is (the node's objects: axis 1), and its index as it names it."""
        n, first = object_axis(index)
        if 2 <= n <= len(self.others) + 1:
            return self.others[n - 2], first
        return self, index

    def on_write(self, index: int, subindex: int, data: bytes) -> None:
        drive, own = self._routed(index)
        if drive is self:
            super().on_write(index, subindex, data)
        else:
            drive.on_write(own, subindex, data)

    def after_write(self, index: int) -> None:
        drive, own = self._routed(index)
        if drive is self:
            super().after_write(index)
        else:
            drive.after_write(own)

    def on_rpdo(self, number: int, *, synchronous: bool) -> None:
        """RPDO ``number`` to the axes whose objects it maps (the node's objects: axis 1).

        Parameters
        ----------
        number : int
            The RPDO, 0-based.
        synchronous : bool
            Applied at the next SYNC.
        """
        pdo = next((p for p in self.pdos.tables.rpdos if p.number == number), None)
        axes = {object_axis(index)[0] for index, *_ in pdo.slices} if pdo is not None else {1}
        if axes & {0, 1}:
            super().on_rpdo(number, synchronous=synchronous)
        for d in self.others:
            if d.number in axes:
                d.on_rpdo(number, synchronous=synchronous)

    def on_sync_latch(self, timestamp: float) -> None:
        super().on_sync_latch(timestamp)
        for d in self.others:
            d.on_sync_latch(timestamp)

    def on_reset(self, *, application: bool) -> None:
        super().on_reset(application=application)
        for d in self.others:
            d.on_reset(application=application)

    def on_abort_connection(self, what: str, code: int) -> None:
        """The host is lost: each axis reacts by its own 0x6007.

        Parameters
        ----------
        what : str
            What was lost, in words.
        code : int
            The EMCY code to send.
        """
        super().on_abort_connection(what, code)
        for d in self.others:
            d.on_abort_connection(what, code)
