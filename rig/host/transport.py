"""Where a run's axes are: the network they join and everything that depends on which one it is.

A ``Transport`` owns the network, its taps (the trace), its pacing choice (how a cycle starts,
``rig.host.pacing``), what set-up's waits for a drive call to let time pass (``idle``), the
watches of other masters and producers, and the close. The session composes a transport, the
axes, a law and a recorder and asks the transport, never which one it is, as python-can's
``Bus`` hides its interface behind one contract. ``rig.host.transports.open_transport`` picks one:

- ``rig.host.emulation.EmulatedWorld`` (``--emulate``): the emulated world in this process,
  in lock-step by the host's SYNCs (imported only then: a run on a real bus loads no emulator);
- ``CanBus``: a CAN bus through python-can, in real time (the host's, the kernel's or another
  device's SYNC) or in lock-step against ``rig emulate`` in another process;
- ``ModbusOnly``: no CAN bus, Modbus axes only: the loop keeps the deadlines.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any

from drivers.base import AxisDriver
from drivers.bus import ReceiveWatch, open_bus, scan_command
from drivers.canopen_axis import CanopenAxis
from drivers.master_watch import MasterWatch
from drivers.producer_watch import ProducerWatch
from rig.config import AxisConfig, RigConfig
from rig.host.bus_load import bus_load, warn_bus_load
from rig.host.heartbeat import HostHeartbeat
from rig.host.pacing import ExternalSync, FreeRun, HostSync, KernelSync, Pacing, WireLockstep
from rig.host.realtime import receive_threads
from rig.host.time_mode import TimeModeProbe
from rig.host.timebase import Timebase
from rig.host.trace import TracedNetwork, attach_received, detach_received

__all__ = ["CanBus", "ModbusOnly", "Transport", "canopen_axes"]

log = logging.getLogger(__name__)

Tap = Callable[[Any], None]


def canopen_axes(axes: Sequence[AxisDriver]) -> list[CanopenAxis]:
    """The axes on the CAN network (CiA 402 drives, CiA 406 encoders).

    Parameters
    ----------
    axes : Sequence[AxisDriver]
        The run's axes.

    Returns
    -------
    list[CanopenAxis]
        Those that are CANopen axes, in order.
    """
    return [a for a in axes if isinstance(a, CanopenAxis)]


class Transport:
    """Base: the defaults of a transport without a CAN bus of its own (module docstring).

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    timebase : Timebase
        The run's clock.
    """

    network: Any
    producers: ProducerWatch | None = None  #: another producer on a TPDO's COB-ID (the loop's stop)
    master_watch: MasterWatch | None = None  #: another master on a real CAN bus
    emulation: Any = None  #: the emulated world in this process (``rig.host.emulation.Emulation``)

    def __init__(self, cfg: RigConfig, timebase: Timebase) -> None:
        self.cfg = cfg
        self.timebase = timebase

    def endpoint(self, a: AxisConfig) -> AxisConfig:
        """``a`` pointed at its device (the emulated world's: where it serves).

        Parameters
        ----------
        a : AxisConfig
            The axis's table.

        Returns
        -------
        AxisConfig
            The table the axis's driver is opened with.
        """
        return a

    def wait(self, timeout: float) -> float:
        """The wall-clock time to wait for a drive to reach a state.

        Parameters
        ----------
        timeout : float
            [s] configured.

        Returns
        -------
        float
            [s] to wait.
        """
        return timeout

    def attach(self, axis: AxisDriver) -> None:
        """``axis`` joined the network (before its set-up).

        Parameters
        ----------
        axis : AxisDriver
            The axis.
        """

    def idle(self) -> Callable[[], None] | None:
        """What set-up calls while it waits for a drive (``AxisDriver.idle``).

        Returns
        -------
        Callable[[], None] | None
            ``CanBus`` in lock-step: the SYNC's send (time passes only by SYNCs there); None: the
            drivers' own short sleep.
        """
        return None

    def add_tap(self, tap: Tap) -> None:
        """``tap`` sees every frame on the network (the trace).

        Parameters
        ----------
        tap : Tap
            Takes a ``can.Message``.
        """

    def remove_tap(self, tap: Tap) -> None:
        """``tap`` sees no more frames (idempotent).

        Parameters
        ----------
        tap : Tap
            As given to `add_tap`.
        """

    def before_setup(self) -> None:
        """Before any NMT command or SDO (``CanBus``: another master is refused)."""

    def time_probe(self, axes: Sequence[AxisDriver]) -> TimeModeProbe | None:
        """The heartbeats that tell how each node keeps time (``rig.host.time_mode``).

        Parameters
        ----------
        axes : Sequence[AxisDriver]
            The run's axes.

        Returns
        -------
        TimeModeProbe | None
            ``CanBus`` with the host's SYNC and a CANopen axis: the probe; else None.
        """
        return None

    def after_setup(self, axes: Sequence[AxisDriver]) -> None:
        """Every axis is set up.

        ``CanBus``: every CANopen axis's supervision watches for another master's RPDOs to it (its own
        RPDO's COB-ID too, where the mapping put it elsewhere) and NMT commands.

        Parameters
        ----------
        axes : Sequence[AxisDriver]
            The run's axes.
        """

    def pacing(self, axes: Sequence[AxisDriver]) -> Pacing:
        """How a cycle starts, after every axis is enabled (``rig.host.pacing``).

        Parameters
        ----------
        axes : Sequence[AxisDriver]
            The run's axes.

        Returns
        -------
        Pacing
            ``FreeRun`` here.
        """
        return FreeRun()

    def bus_load(self, axes: Sequence[AxisDriver]) -> dict[str, Any]:
        """The cycle's share of the bus (``rig.host.bus_load``), warned above the whole period.

        Parameters
        ----------
        axes : Sequence[AxisDriver]
            The run's axes.

        Returns
        -------
        dict[str, Any]
            ``CanBus`` in real time with a CANopen axis: ``bus_load``'s figures; else {}.
        """
        return {}

    def heartbeat(self, axes: Sequence[AxisDriver]) -> Callable[[int], None] | None:
        """The host's heartbeat where a CANopen axis watches it (``[bus] heartbeat`` > 0).

        Parameters
        ----------
        axes : Sequence[AxisDriver]
            The run's axes.

        Returns
        -------
        Callable[[int], None] | None
            ``HostHeartbeat.beat``; None: no heartbeat.
        """
        bus = self.cfg.bus
        if bus.heartbeat <= 0.0 or not canopen_axes(axes):
            return None
        return HostHeartbeat(self.network, bus.host_node, bus.heartbeat, self.timebase.period).beat

    def receive_threads(self) -> list[Any]:
        """The threads that receive the network's frames (real time: given its priority).

        Returns
        -------
        list[Any]
            ``rig.host.realtime.receive_threads``'s.
        """
        return receive_threads(self.network)

    def scan_hint(self) -> str:
        """The ``rig scan`` line for this run's bus.

        Returns
        -------
        str
            The command.
        """
        b = self.cfg.bus
        return scan_command(b.interface, b.channel, b.bitrate or None, b.host, b.port)

    def unwatch(self) -> None:
        """Stop watching for other masters and producers (before the axes close)."""

    def close(self) -> None:
        """Close the network (idempotent; after the axes)."""


class ModbusOnly(Transport):
    """No CAN bus: every axis is a Modbus one and opens its own connection.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    timebase : Timebase
        The run's clock.
    """

    def __init__(self, cfg: RigConfig, timebase: Timebase) -> None:
        super().__init__(cfg, timebase)
        self.network = TracedNetwork()  #: joined by no axis


class CanBus(Transport):
    """A CAN bus of ``[bus]``, opened here; the watches of other masters and producers on it.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    timebase : Timebase
        The run's clock.
    """

    def __init__(self, cfg: RigConfig, timebase: Timebase) -> None:
        super().__init__(cfg, timebase)
        self.network = TracedNetwork()
        self._rx_taps: dict[int, Callable[[Any], None]] = {}  #: id(tap) -> its listener
        b = cfg.bus
        extra = {"host": b.host, "port": b.port} if b.interface == "socketcand" else {}
        self._bus: Any = open_bus(b.interface, b.channel, bitrate=b.bitrate or None, **extra)
        try:
            self.network.bus = self._bus
            self.network.connect()
            self.network.notifier.add_listener(ReceiveWatch())  # a lost bus: a safe stop, not a dead thread
            nodes = [a.node_id for a in cfg.axes if a.kind != "modbus"]  # heard from the bus's opening
            watch = self.watch = self.master_watch = MasterWatch(
                self.network, nodes, sync=b.sync != "external"
            )
            self.producers = ProducerWatch(self.network, echoes=lambda: watch.echoes)
        except BaseException:
            self.close()
            raise

    def attach(self, axis: AxisDriver) -> None:
        if isinstance(axis, CanopenAxis):  # before set-up: a TPDO is counted from its slot's making
            axis.producer_watch = self.producers

    def idle(self) -> Callable[[], None] | None:
        return self.network.sync.transmit if self.timebase.lockstep else None

    def add_tap(self, tap: Tap) -> None:
        self.network.tx_tap = tap  # every frame sent,
        self._rx_taps[id(tap)] = attach_received(self.network, tap)  # and every frame received

    def remove_tap(self, tap: Tap) -> None:
        if self.network.tx_tap is tap:
            self.network.tx_tap = None
        listener = self._rx_taps.pop(id(tap), None)
        if listener is not None:
            detach_received(self.network, listener)

    def before_setup(self) -> None:
        self.watch.check(max(2.0 * self.timebase.period, 0.1))

    def time_probe(self, axes: Sequence[AxisDriver]) -> TimeModeProbe | None:
        on_bus = canopen_axes(axes)
        if not on_bus or self.cfg.bus.sync == "external":
            return None
        return TimeModeProbe(self.network, on_bus)

    def after_setup(self, axes: Sequence[AxisDriver]) -> None:
        watch = self.watch
        for axis in canopen_axes(axes):
            rpdo = getattr(getattr(axis, "data", None), "rpdo", None)
            if rpdo is not None:
                watch.add_rpdo(rpdo.cob_id, axis.node_id)
            axis.master_watch = watch

    def pacing(self, axes: Sequence[AxisDriver]) -> Pacing:
        pacing = self._pacing(canopen_axes(axes))
        if pacing.sends_sync:  # a SYNC heard from now on is a second producer's
            self.watch.watch_sync()
        return pacing

    def _pacing(self, on_bus: list[CanopenAxis]) -> Pacing:
        cfg, period = self.cfg, self.timebase.period
        if not on_bus:
            return FreeRun()
        timeout = min(a.limits.watchdog_periods for a in cfg.axes) * period
        if cfg.bus.sync == "external":
            return ExternalSync(self.network, on_bus, timeout)
        if self.timebase.lockstep:
            # the answers' wait is the transport's, not the emulated time's: at least the watchdog
            # in seconds (3 periods of 0.4 ms expired before socketcand's first answer came)
            wait = max(timeout, min(a.limits.watchdog for a in cfg.axes))
            return WireLockstep(self.network, on_bus, wait)
        if cfg.bus.interface == "socketcan":
            return KernelSync(self.network, on_bus, period, timeout)
        return HostSync(self.network, on_bus, cfg.run.answer_budget or period / 2.0)

    def bus_load(self, axes: Sequence[AxisDriver]) -> dict[str, Any]:
        on_bus = canopen_axes(axes)
        if self.timebase.lockstep or not on_bus:
            return {}
        figures = bus_load(on_bus, self.timebase.period, self.cfg.bus.bitrate)
        warn_bus_load(figures)
        return figures

    def unwatch(self) -> None:
        if self.producers is not None:
            self.producers.close()
        self.watch.close()

    def close(self) -> None:
        if self._bus is None:
            return
        try:
            self.network.disconnect()
        except Exception as exc:  # the bus was lost: its error is in the summary already
            log.warning("the bus did not close cleanly: %s", exc)
        self._bus = None
