"""What a device profile says once read (``plant_emulator.device_profile`` reads the TOML):
``DeviceProfile`` and its parts (units, timing, reactions, homing, manufacturer objects).
``DeviceProfile.check_against(od)`` checks the profile against its EDS (modes against 0x6502,
increments where 0x608F is absent, a fixed mapping that the EDS would let be written).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from drivers.maps import cia
from drivers.maps.cia import MODE_BITS, Mode
from drivers.maps.cia402_needs import EMULATED, needed, require
from drivers.maps.logical import axes_of
from drivers.maps.mode_names import MODE_NAMES

__all__ = ["DeviceProfile", "Homing", "ManufacturerObject", "Reactions", "Timing", "Units"]

#: the mode names of a profile: the configuration's, and "hm" for homing
PROFILE_MODES: dict[str, Mode] = {**MODE_NAMES, "hm": Mode.HOMING}
ROLES = ("", "command-latency")


@dataclass(frozen=True)
class Units:
    """What the EDS may not say about units (``plant_emulator.device_profile``: ``[units]``)."""

    counts_per_rev: int = 0  #: increments per motor revolution where 0x608F is absent; 0: not given
    position: int = 0  #: 0x60A8 code where the EDS lacks 0x60A8; 0: the factor group (increments)
    velocity: int = 0  #: 0x60A9 code where the EDS lacks 0x60A9; 0: position units per second


@dataclass(frozen=True)
class Timing:
    """How long the drive takes [s]; lock-step has no time between SYNCs, so there the SDO and
    mode-switch times count in SYNC periods only where a SYNC passes."""

    sdo_response: float = 0.0  #: [s] an SDO request to its answer
    pdo_latency: float = 0.0  #: [s] an event RPDO applied after its receipt
    mode_switch: float = 0.0  #: [s] a change of 0x6060 to 0x6061 showing it


@dataclass(frozen=True)
class Reactions:
    """Defaults of the stop option codes, and decelerations [rad/s^2] where their objects are absent."""

    quick_stop: int = 2  #: 0x605A
    fault: int = 2  #: 0x605E
    abort_connection: int = 1  #: 0x6007
    halt: int = 1  #: 0x605D
    profile_deceleration: float = 1000.0  #: [rad/s^2] where 0x6084 is absent
    quick_stop_deceleration: float = 2000.0  #: [rad/s^2] where 0x6085 is absent


@dataclass(frozen=True)
class Homing:
    methods: tuple[int, ...] = (35, 37)  #: 0x6098 values the drive accepts
    switch_position: float = 0.5  #: [rad] the home switch is on at shaft angles >= this


@dataclass(frozen=True)
class ManufacturerObject:
    """An object in 0x2000-0x5FFF with the meaning the drive gives it."""

    index: int  #: 0x2000-0x5FFF
    name: str  #: its name
    role: str = ""  #: what the toolkit uses it for ("command-latency" or "")
    harmful: bool = False  #: a write may harm the drive: refused by ``rig drive``


@dataclass(frozen=True)
class DeviceProfile:
    """One drive's profile; its sections as ``plant_emulator.device_profile``'s module docstring says."""

    name: str  #: ``[device] name``
    description: str  #: ``[device] description``
    eds: Path  #: the EDS, beside the profile
    source: Path  #: the TOML file
    modelled_on: str = ""  #: the product it is a twin of
    physics: str = "dc-servo"  #: the preset whose motor is behind the drive
    params: Mapping[str, Any] = field(default_factory=dict)  #: ``[physics.params]``, the preset's parameters
    node_id: int = 1  #: its default node-ID
    axes: int = 1  #: logical devices of the drive, each with a motor of ``physics``
    modes: tuple[Mode, ...] = ()  #: ``[modes] supported`` (where the EDS has no 0x6502)
    csp_enable: str = "target"  #: enabled in CSP: go for 0x607A ("target") or hold ("hold")
    mapping: str = "remappable"  #: ``[pdo] mapping``: "remappable" or "fixed"
    units: Units = Units()  #: ``[units]``
    timing: Timing = Timing()  #: ``[timing]``
    reactions: Reactions = Reactions()  #: ``[reactions]``
    homing: Homing = Homing()  #: ``[homing]``
    manufacturer: tuple[ManufacturerObject, ...] = ()  #: ``[manufacturer.0xIIII]`` objects
    emcy: Mapping[int, str] = field(default_factory=dict)  #: ``[emcy]`` code -> text

    def role_object(self, role: str) -> int | None:
        """The manufacturer object that plays ``role``, or None.

        Parameters
        ----------
        role : str
            A role (``ROLES``).

        Returns
        -------
        int | None
            Its object's index, or None.
        """
        return next((m.index for m in self.manufacturer if m.role == role), None)

    @functools.cached_property
    def harmful(self) -> frozenset[int]:
        """The indices of the harmful manufacturer objects (asked at every object write)."""
        return frozenset(m.index for m in self.manufacturer if m.harmful)

    def check_against(self, od: Any) -> tuple[Mode, ...]:
        """Check this profile against its object dictionary ``od`` (on a drive of several axes, one
        axis's view: ``drivers.maps.logical``), which must have what an emulated drive and each of
        its modes need (``drivers.maps.cia402_needs``); the drive's modes.

        Parameters
        ----------
        od : Any
            Its object dictionary (one axis's view).

        Returns
        -------
        tuple[Mode, ...]
            The drive's modes.

        Raises
        ------
        ConfigError
            If the axes, modes, increments or mapping disagree with ``od``, or ``od`` lacks what they need.
        """
        where = f"{self.source}"
        axes = axes_of(od)
        if axes != self.axes:
            raise ConfigError(
                f"{where}: [device] axes = {self.axes} but {self.eds.name} describes {axes} (the logical "
                "devices with a statusword, 0x6041 + 0x800 per axis); give one of them"
            )
        modes = self.modes
        if cia.SUPPORTED_MODES in od:
            bits = _default(od[cia.SUPPORTED_MODES])
            from_eds = tuple(m for m, bit in MODE_BITS.items() if bits & bit)
            if modes and set(modes) != set(from_eds):
                raise ConfigError(
                    f"{where}: [modes] supported = {_names(modes)} but 0x6502 in {self.eds.name} "
                    f"says {_names(from_eds)}; give one of them"
                )
            modes = from_eds
        if not modes:
            raise ConfigError(f"{where}: {self.eds.name} has no 0x6502: set [modes] supported")
        what = f"the emulated drive of {where} in its modes ({', '.join(_names(modes))})"
        require(od, [*EMULATED, *(i for m in modes for i in needed(m))], source=str(self.eds), what=what)
        if cia.POSITION_ENCODER_RESOLUTION not in od and not self.units.counts_per_rev:
            raise ConfigError(f"{where}: {self.eds.name} has no 0x608F: set [units] counts_per_rev")
        if self.mapping == "fixed":
            for index in (cia.RPDO_MAP, cia.TPDO_MAP):
                if index in od and _writable(od[index]):
                    raise ConfigError(
                        f'{where}: [pdo] mapping = "fixed" but 0x{index:04X} in {self.eds.name} is writable'
                    )
        return modes


def _default(obj: Any) -> int:
    value = obj.default if obj.default is not None else obj.value
    return int(value or 0)


def _writable(obj: Any) -> bool:
    subs = obj.values() if hasattr(obj, "values") else [obj]
    return any(s.writable for s in subs if getattr(s, "subindex", 1))


def _names(modes: tuple[Mode, ...]) -> list[str]:
    by_mode = {m: n for n, m in PROFILE_MODES.items()}
    return [by_mode.get(m, str(int(m))) for m in modes]
