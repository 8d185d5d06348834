"""Which transport a run gets (``rig.host.transport``): the emulated world where it emulates
(``rig.host.emulation``, imported only then), a CAN bus where a CANopen axis is configured, else
none for Modbus only, and what the run's mode needs of the file before one is opened. Above both
the transports and the emulated world, so neither imports the other."""

from __future__ import annotations

from drivers.errors import ConfigError
from rig.config import RigConfig
from rig.host.timebase import Timebase
from rig.host.transport import CanBus, ModbusOnly, Transport

__all__ = ["check_transport", "open_transport"]


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


def check_transport(cfg: RigConfig, *, emulate: bool) -> None:
    """What the run's mode needs of the file, before anything is opened.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    emulate : bool
        The run emulates in this process (else it is on a real bus).

    Raises
    ------
    ConfigError
        A real bus without ``[run] period``; ``emulate`` without a preset or device for the
        CANopen axes.
    """
    if emulate:
        on_bus = [a.name for a in cfg.axes if a.kind != "modbus"]
        if on_bus and cfg.emulator.physics is None:
            raise ConfigError(
                f"{cfg.source}: --emulate needs [emulator] preset or device for the CANopen axes {on_bus}"
            )
    elif not cfg.run.period > 0.0:
        raise ConfigError(
            f"{cfg.source}: [run] period must be set (> 0 s) for a real bus; without hardware, run it "
            "with --emulate (the emulator in this process) or against `rig emulate` in another"
        )
