"""A synchronous in-process CAN bus for lock-step runs: no threads in the data path.

``SyncHub`` is the wire; each ``SyncBus`` on it is a python-can ``BusABC``.
``send`` delivers the frame, before it returns, to every other bus on the hub:
to its ``listeners`` (plain callables, called in order) and, unless the bus was
made with ``queue=False``, to a queue that ``recv`` reads. A device that answers
a frame from inside its listener therefore answers within the sender's
``send``: after the host sends SYNC, every synchronous TPDO has arrived.

Timestamps come from ``hub.clock`` (seconds of emulated time), so traces are
identical run to run. ``attach_network`` joins a canopen ``Network`` to a bus
without canopen's Notifier thread.
"""

from __future__ import annotations

import collections
import logging
from collections.abc import Callable, Mapping
from typing import Any

import can
import canopen
from canopen.network import NodeScanner

from drivers.maps.cia import COB_SYNC
from plant_emulator.device_profile import DeviceProfile
from plant_emulator.frame import Frame
from plant_emulator.presets import PRESETS, build_preset, build_twin, preset_params

__all__ = ["LockstepBench", "SyncBus", "SyncHub", "SyncNetwork", "attach_network"]

Listener = Callable[[can.Message], None]
_FOUND_BY = frozenset(NodeScanner.SERVICES)  #: the services by which canopen's scanner finds a node
log = logging.getLogger(__name__)


class SyncHub:
    """The shared wire of ``SyncBus`` instances; ``clock`` is emulated time [s]."""

    def __init__(self) -> None:
        self.buses: list[SyncBus] = []
        self.clock = 0.0
        self.frames = 0  #: frames carried so far
        self.taps: list[Listener] = []  #: see every frame (a CAN trace)
        self.drop: Callable[[can.Message], bool] | None = None  #: fault injection: True loses the frame
        #: set: every frame is marked Tx (``is_rx`` False) if sent on the bus of this channel, else
        #: Rx, before the taps see it (a trace from that node's side); None: left as sent
        self.tx_channel: str | None = None

    def bus(self, *, queue: bool = True, channel: str = "sync0") -> SyncBus:
        """A new bus on this hub.

        Parameters
        ----------
        queue : bool, optional
            Keep received frames for ``recv`` (else only the taps and notifiers see them).
        channel : str, optional
            The channel name it reports.

        Returns
        -------
        SyncBus
            The bus.
        """
        return SyncBus(self, queue=queue, channel=channel)

    def deliver(self, sender: SyncBus, msg: can.Message) -> None:
        """``msg`` as sent on ``sender`` (``SyncBus.send``).

        Parameters
        ----------
        sender : SyncBus
            The bus it was sent on.
        msg : can.Message
            The frame.
        """
        sender.send(msg)


class SyncBus(can.BusABC):
    """One node's connection to a ``SyncHub`` (see the module docstring).

    Parameters
    ----------
    hub : SyncHub
        The hub it joins.
    queue : bool, optional
        Keep received frames for ``recv``.
    channel : str, optional
        The channel name it reports.
    **kwargs : Any
        python-can's ``BusABC`` arguments.
    """

    def __init__(self, hub: SyncHub, *, queue: bool = True, channel: str = "sync0", **kwargs: Any) -> None:
        self.hub = hub
        self.listeners: list[Listener] = []
        self._queue: collections.deque[can.Message] | None = collections.deque() if queue else None
        self.channel_info = channel
        super().__init__(channel=channel, **kwargs)
        hub.buses = [*hub.buses, self]

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Deliver ``msg`` to every other bus on the hub, synchronously (the hub's taps first).

        Parameters
        ----------
        msg : can.Message
            The frame.
        timeout : float | None, optional
            Ignored (the delivery is synchronous).
        """
        hub = self.hub
        frame = msg  # the sender's frame, stamped; receivers must not change it
        frame.timestamp = hub.clock
        frame.channel = self.channel_info
        if hub.drop is not None and hub.drop(frame):
            return
        hub.frames += 1
        if hub.tx_channel is not None:
            frame.is_rx = frame.channel != hub.tx_channel
        for tap in hub.taps:
            tap(frame)
        for bus in hub.buses:  # a snapshot: a bus joining or leaving replaces the list
            if bus is not self:
                if bus._queue is not None:
                    bus._queue.append(frame)
                for listener in bus.listeners:
                    listener(frame)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if self._queue:
            return self._queue.popleft(), False
        return None, False

    def shutdown(self) -> None:
        self.hub.buses = [b for b in self.hub.buses if b is not self]
        super().shutdown()


def attach_network(network: Any, bus: SyncBus) -> None:
    """Join a canopen ``Network`` to ``bus``: frames go straight to ``network.notify`` (to its
    subscribers and node scanner, as canopen's ``notify`` does, without the call where the network
    does not override it; canopen's scanner is asked only about a frame that would add a node).

    A frame its handler cannot parse (wrong length, bad command) is logged and
    dropped, as canopen's own listener does on a real bus: a malformed frame
    must not take down the node that received it.

    Parameters
    ----------
    network : Any
        A canopen ``Network``.
    bus : SyncBus
        The bus it joins.
    """
    network.bus = bus
    own_notify = type(network).notify is not canopen.Network.notify

    def _to_network(msg: can.Message) -> None:
        if msg.is_error_frame or msg.is_remote_frame:
            return
        can_id = msg.arbitration_id
        try:
            if own_notify:
                network.notify(can_id, msg.data, msg.timestamp)
                return
            subscribers = network.subscribers
            if can_id in subscribers:
                for callback in subscribers[can_id]:
                    callback(can_id, msg.data, msg.timestamp)
            scanner = network.scanner
            if type(scanner) is not NodeScanner:
                scanner.on_message_received(can_id)
            elif can_id & 0x780 in _FOUND_BY and can_id & 0x7F and can_id & 0x7F not in scanner.nodes:
                scanner.on_message_received(can_id)  # (canopen's condition: a call only where it adds)
        except Exception as exc:
            log.warning("dropped frame 0x%03X [%s]: %s", can_id, bytes(msg.data).hex(), exc)

    bus.listeners.append(_to_network)


class SyncNetwork(canopen.Network):
    """canopen's ``Network`` for a ``SyncBus`` (``LockstepBench.host``): ``send_message`` does what
    canopen's does, a classic data frame made as a ``Frame`` and without the check of a receive
    thread where there is none (a frame is delivered, and answered, within the send)."""

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        """Send a frame as canopen's ``Network.send_message`` does (see the class).

        Parameters
        ----------
        can_id : int
            The identifier.
        data : bytes
            The data bytes.
        remote : bool, optional
            A remote frame.

        Raises
        ------
        RuntimeError
            If the network has no bus.
        """
        if remote or can_id > 0x7FF or self.notifier is not None:
            super().send_message(can_id, data, remote)
            return
        if not self.bus:
            raise RuntimeError("Not connected to CAN bus")
        frame = Frame(can_id, data)
        with self.send_lock:
            self.bus.send(frame)


class LockstepBench:
    """A preset on an in-process ``SyncHub``, with a host-side canopen ``Network`` to drive it.

    ``sync()`` advances emulated time by one period and sends SYNC from the host:
    when it returns, the devices have stepped their physics and their TPDOs are
    in the host's PDO maps.

    Parameters
    ----------
    preset : str
        The preset's name (``build_preset``).
    params : Mapping[str, object] | Any, optional
        Its parameters by name, or its dataclass built already.
    device : DeviceProfile | None, optional
        A drive's twin to emulate instead of the toolkit's drive.
    """

    def __init__(
        self, preset: str, params: Mapping[str, object] | Any = None, *, device: DeviceProfile | None = None
    ) -> None:
        """Preset ``preset`` with ``params`` (typed values by name, see ``build_preset``, or the
        preset's dataclass built already); with ``device``, that drive's twin instead
        (``build_twin``: its physics preset and ``params``). Bad parameters open nothing."""
        name = device.physics if device else preset
        if not isinstance(params, PRESETS.get(name, ())):
            params = preset_params(name, {**(device.params if device else {}), **(params or {})})
        self.hub = SyncHub()
        self.device_network = canopen.Network()
        attach_network(self.device_network, self.hub.bus(queue=False, channel="emulator"))
        self.host = SyncNetwork()
        attach_network(self.host, self.hub.bus(queue=False, channel="host"))
        try:
            if device is not None:
                self.devices, self.period = build_twin(device, self.device_network, params)
            else:
                self.devices, self.period = build_preset(preset, self.device_network, params)
        except BaseException:
            self.close()
            raise
        self.syncs = 0
        for d in self.devices:
            d.boot()

    def sync(self) -> None:
        """One period of emulated time, then a SYNC from the host."""
        self.syncs += 1
        self.hub.clock = self.syncs * self.period  # from a count: no drift by rounding
        self.host.send_message(COB_SYNC, b"")

    def close(self) -> None:
        """Shut both networks' buses down."""
        for net in (self.host, self.device_network):
            if net.bus is not None:
                net.bus.shutdown()
