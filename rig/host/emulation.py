"""The emulated world of a ``--emulate`` run, in this process.

The configured preset on the in-process lock-step bus (``plant_emulator.lockstep``),
an emulated Modbus inverter for every Modbus axis (TCP on 127.0.0.1, or RTU over a
pseudo-terminal pair when the axis names a serial device), and the fault
injector of ``[faults]``. The host's canopen network is ``network``; Modbus axes
are pointed at their inverters by ``endpoint``. Everything is built from what the configuration
checked when it was loaded (``rig.config.emulator``: the built preset, the inverters' values);
nothing is checked again.

``EmulatedWorld`` is the transport of such a run (``rig.host.transport``): the host's frames go
to the emulated devices in this process, a cycle is ``InProcessLockstep``'s (the SYNC delivered
at once, the inverters stepped a period), and set-up's waits for a drive send a SYNC.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import canopen

from drivers.base import AxisDriver
from drivers.maps import modbus_map
from plant_emulator.faults import FAULT_NAMES, FaultInjector, FaultPlan
from plant_emulator.lockstep import LockstepBench
from rig.config import AxisConfig, RigConfig
from rig.host.pacing import InProcessLockstep, Pacing
from rig.host.timebase import Timebase
from rig.host.transport import Tap, Transport

__all__ = ["HANG_GUARD", "EmulatedWorld", "Emulation"]

#: [s] the least wait for an emulated drive's state in lock-step (``EmulatedWorld.wait``): a hang guard
HANG_GUARD = 30.0


class Emulation:
    """The emulated devices of a ``--emulate`` run (module docstring); ``close`` stops everything it started.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration (its preset, inverters and faults as checked then).
    """

    def __init__(self, cfg: RigConfig) -> None:
        #: lock-step: the inverters' physics is stepped by the host; real time: on the wall clock
        self._dt = None if cfg.run.time == "lockstep" else 0.005
        self.bench: LockstepBench | None = None
        self.injector: FaultInjector | None = None
        self.inverters: dict[str, tuple[Any, Any]] = {}  #: axis name -> (InverterModel, InverterServer)
        self._links: list[Any] = []
        self._taps: list[Callable[[Any], None]] = []  #: see ``add_tap``
        self._endpoints: dict[str, dict[str, Any]] = {}
        if cfg.emulator.physics is not None:
            self.bench = self._bench(cfg)
        self.network: Any = self.bench.host if self.bench else canopen.Network()
        try:
            for a in cfg.axes:
                if a.kind == "modbus":
                    self._start_inverter(cfg, a)
            self._inject(cfg)
        except BaseException:
            self.close()
            raise

    def _bench(self, cfg: RigConfig) -> LockstepBench:
        """The preset's devices, or the twin of ``device`` (whose EDS its axis then uses)."""
        profile = cfg.emulator.profile
        bench = LockstepBench(cfg.emulator.preset, cfg.physics, device=profile)
        if profile is not None:
            for a in cfg.axes:
                if a.kind == "cia402" and a.node_id == profile.node_id and not a.eds:
                    self._endpoints[a.name] = {"eds": str(profile.eds)}
        return bench

    def _start_inverter(self, cfg: RigConfig, a: AxisConfig) -> None:
        from plant_emulator.inverter_model import InverterModel
        from plant_emulator.modbus_inverter import InverterServer
        from plant_emulator.pty_link import PtyLink

        model = InverterModel(modbus_map(a.map), **cfg.emulator.inverter)
        if a.serial:  # RTU: the inverter on one end of a pty pair, the axis on the other
            link = PtyLink()
            self._links.append(link)
            server = InverterServer(model, serial=link.port_b, baudrate=a.baudrate, unit=a.unit, dt=self._dt)
            self._endpoints[a.name] = {"serial": link.port_a, "host": ""}
        else:
            server = InverterServer(model, unit=a.unit, dt=self._dt)
        server.start()
        if not a.serial:
            self._endpoints[a.name] = {"host": "127.0.0.1", "port": server.port, "serial": ""}
        self.inverters[a.name] = (model, server)

    def _inject(self, cfg: RigConfig) -> None:
        plan = FaultPlan(**{k: getattr(cfg.faults, k) for k in FAULT_NAMES})
        if plan.active and self.bench is not None:  # without a bench, none is given (rig.config.rules)
            self.injector = FaultInjector(plan, self.bench.hub, self.bench.devices[0])

    def endpoint(self, a: AxisConfig) -> AxisConfig:
        """``a`` pointed at its emulated device.

        Parameters
        ----------
        a : AxisConfig
            The axis's table.

        Returns
        -------
        AxisConfig
            The same, with the emulated device's host, port, serial device or EDS.
        """
        return dataclasses.replace(a, **self._endpoints.get(a.name, {}))

    @property
    def sync(self) -> Callable[[], None] | None:
        """The hub's SYNC (None: no CANopen device)."""
        return self.bench.sync if self.bench else None

    @property
    def steppers(self) -> list[Callable[[float], None]]:
        """The in-process Modbus inverters' physics, stepped one period per cycle in lock-step."""
        if self._dt is not None:
            return []
        return [model.step for model, _ in self.inverters.values()]

    @property
    def devices(self) -> list[Any]:
        """The emulated CANopen devices (none without a preset or device)."""
        return self.bench.devices if self.bench else []

    def add_tap(self, tap: Callable[[Any], None]) -> None:
        """``tap`` sees every frame on the hub; the host's marked Tx, the devices' Rx.

        Parameters
        ----------
        tap : Callable[[Any], None]
            Takes a ``can.Message``.
        """
        if self.bench is not None:
            self.bench.hub.tx_channel = "host"
            self.bench.hub.taps.append(tap)
            self._taps.append(tap)

    def remove_tap(self, tap: Callable[[Any], None]) -> None:
        """``tap`` sees no more frames (idempotent).

        Parameters
        ----------
        tap : Callable[[Any], None]
            As given to `add_tap`.
        """
        if tap in self._taps:
            self._taps.remove(tap)
        if self.bench is not None:
            if tap in self.bench.hub.taps:
                self.bench.hub.taps.remove(tap)
            if not self._taps:
                self.bench.hub.tx_channel = None

    def close(self) -> None:
        """Stop the inverters, the fault injector and the bus (idempotent)."""
        for _, server in self.inverters.values():
            server.stop()
        for link in self._links:
            link.close()
        self._links.clear()
        if self.injector is not None:
            self.injector.shutdown()
            self.injector = None
        if self.bench is not None:
            self.bench.close()


class EmulatedWorld(Transport):
    """The transport of an ``--emulate`` run: its `Emulation` (module docstring).

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    timebase : Timebase
        The run's clock.
    """

    def __init__(self, cfg: RigConfig, timebase: Timebase) -> None:
        super().__init__(cfg, timebase)
        self.world = self.emulation = Emulation(cfg)
        self.network = self.world.network

    def endpoint(self, a: AxisConfig) -> AxisConfig:
        return self.world.endpoint(a)

    def wait(self, timeout: float) -> float:
        """The wall-clock time to wait for a drive to reach a state: in lock-step at least ``HANG_GUARD``.

        The emulated drive answers as soon as this process runs: the wait only guards against a hang
        (docs/emulator.md).

        Parameters
        ----------
        timeout : float
            [s] configured.

        Returns
        -------
        float
            [s] to wait.
        """
        return max(timeout, HANG_GUARD) if self.timebase.lockstep else timeout

    def idle(self) -> Callable[[], None] | None:
        """A SYNC: emulated time passes by SYNCs.

        Returns
        -------
        Callable[[], None] | None
            The hub's SYNC (None: no CANopen device).
        """
        return self.world.sync

    def add_tap(self, tap: Tap) -> None:
        self.world.add_tap(tap)

    def remove_tap(self, tap: Tap) -> None:
        self.world.remove_tap(tap)

    def pacing(self, axes: Sequence[AxisDriver]) -> Pacing:
        return InProcessLockstep(self.timebase.period, self.world.sync, self.world.steppers)

    def close(self) -> None:
        self.world.close()
