"""Which transport a run gets (``rig.host.transport``): the emulated world where it emulates
(``rig.host.emulation``, imported only then), a CAN bus where a CANopen axis is configured, else
none for Modbus only. Above both the transports and the emulated world, so neither imports the
other."""

from __future__ import annotations

from rig.config import RigConfig
from rig.host.timebase import Timebase
from rig.host.transport import CanBus, ModbusOnly, Transport

__all__ = ["open_transport"]


def open_transport(cfg: RigConfig, timebase: Timebase, *, emulate: bool) -> Transport:
    """The transport of ``cfg``'s run.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    timebase : Timebase
        The run's clock.
    emulate : bool
        The emulated world in this process.

    Returns
    -------
    Transport
        ``EmulatedWorld``, ``CanBus`` or ``ModbusOnly``.
    """
    if emulate:
        from rig.host import emulation  # the emulator only where it runs

        return emulation.EmulatedWorld(cfg, timebase)
    if any(a.kind != "modbus" for a in cfg.axes):
        return CanBus(cfg, timebase)
    return ModbusOnly(cfg, timebase)
