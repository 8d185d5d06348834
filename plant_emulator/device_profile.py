"""Device profiles: what a drive's EDS cannot say, as data (TOML), to build its emulated twin.

An EDS lists a drive's objects, their types, access, mappability and defaults.
It does not say which modes the drive has where it lacks 0x6502, what its
increments are where it lacks 0x608F, whether it lets its PDOs be remapped, how
long it takes to answer, how it stops, or what the motor behind it is. A profile
says that. One file per drive, next to its EDS; its sections (every key optional but
``[device] eds``; docs/emulator.md's "A twin of your own drive" shows them all): ``[device]`` name,
description, modelled_on, eds, physics (the preset whose motor is behind the drive),
node_id, axes (a drive of several axes on one node, ``drivers.maps.logical``: a motor of the
physics behind each); ``[physics.params]`` the preset's parameters; ``[modes] supported`` (only where the
EDS has no 0x6502), csp_enable ("target": enabled in CSP, the drive goes for 0x607A,
absolute, as CiA 402 has it; "hold": it holds where it stands until a new target comes);
``[units]`` counts_per_rev, position, velocity (where the EDS lacks
0x608F, 0x60A8, 0x60A9); ``[pdo] mapping`` (remappable | fixed); ``[timing]`` sdo_response,
pdo_latency, mode_switch [s]; ``[reactions]`` quick_stop, fault, abort_connection, halt (the
defaults of 0x605A, 0x605E, 0x6007, 0x605D) and profile_deceleration,
quick_stop_deceleration [rad/s^2] (where 0x6084/0x6085 are absent); ``[homing]`` methods,
switch_position [rad]; ``[manufacturer.0xIIII]`` name, harmful, role
("command-latency": the toolkit's event-RPDO latency [us]); ``[emcy]`` code = text.

Every key is checked: an unknown key, a wrong type or a value out of range is a
``ConfigError`` naming the file and the key. ``check_against(od)`` then checks
the profile against its EDS (modes against 0x6502, increments where 0x608F is
absent, a fixed mapping that the EDS would let be written).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from drivers.files import read_toml
from drivers.maps import cia
from drivers.maps.cia import MODE_BITS, Mode
from drivers.maps.cia402_needs import EMULATED, needed, require
from drivers.maps.logical import MAX_AXES, axes_of
from drivers.maps.mode_names import MODE_NAMES
from drivers.maps.units import SiUnit
from plant_emulator.toml_table import Table

__all__ = [
    "DEVICES_DIR",
    "DeviceProfile",
    "ManufacturerObject",
    "default_profile",
    "device_profile",
    "load_profile",
    "zoo",
]

DEVICES_DIR = Path(__file__).resolve().parent / "devices"
#: the mode names of a profile: the configuration's, and "hm" for homing
PROFILE_MODES: dict[str, Mode] = {**MODE_NAMES, "hm": Mode.HOMING}
ROLES = ("", "command-latency")


@dataclass(frozen=True)
class Units:
    """What the EDS may not say about units (see the module docstring)."""

    counts_per_rev: int = 0  #: increments per motor revolution where 0x608F is absent; 0: not given
    position: int = 0  #: 0x60A8 code where the EDS lacks 0x60A8; 0: the factor group (increments)
    velocity: int = 0  #: 0x60A9 code where the EDS lacks 0x60A9; 0: position units per second


@dataclass(frozen=True)
class Timing:
    """How long the drive takes [s]; lock-step has no time between SYNCs, so there the SDO and
    mode-switch times count in SYNC periods only where a SYNC passes."""

    sdo_response: float = 0.0
    pdo_latency: float = 0.0
    mode_switch: float = 0.0


@dataclass(frozen=True)
class Reactions:
    """Defaults of the stop option codes, and decelerations [rad/s^2] where their objects are absent."""

    quick_stop: int = 2  #: 0x605A
    fault: int = 2  #: 0x605E
    abort_connection: int = 1  #: 0x6007
    halt: int = 1  #: 0x605D
    profile_deceleration: float = 1000.0
    quick_stop_deceleration: float = 2000.0


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
    """One drive's profile; see the module docstring."""

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


# --- loading ---------------------------------------------------------------------------------------
def _hex(text: str, where: str) -> int:
    try:
        return int(text, 0)
    except ValueError:
        raise ConfigError(f"{where}: {text!r} is not a number (write 0x2001)") from None


def _nonnegative(table: Table, key: str, default: float) -> float:
    value = float(table.get(key, float, default))
    if not (math.isfinite(value) and value >= 0.0):
        raise ConfigError(f"{table.where} {key} = {value!r}: must be >= 0")
    return value


def _units(t: Table) -> Units:
    codes = {}
    for key in ("position", "velocity"):
        text = t.get(key, str, "")
        codes[key] = _hex(text, f"{t.where} {key}") if text else 0
        if codes[key]:
            try:
                SiUnit.decode(codes[key])
            except ValueError as exc:
                raise ConfigError(f"{t.where} {key}: {exc}") from None
    cpr = t.get("counts_per_rev", int, 0)
    if cpr < 0:
        raise ConfigError(f"{t.where} counts_per_rev = {cpr}: must be > 0")
    t.done()
    return Units(cpr, codes["position"], codes["velocity"])


def _reactions(t: Table) -> Reactions:
    r = Reactions(
        t.get("quick_stop", int, 2),
        t.get("fault", int, 2),
        t.get("abort_connection", int, 1),
        t.get("halt", int, 1),
        _nonnegative(t, "profile_deceleration", 1000.0),
        _nonnegative(t, "quick_stop_deceleration", 2000.0),
    )
    checks = (
        ("quick_stop", r.quick_stop, 0, 8),
        ("fault", r.fault, 0, 4),
        ("abort_connection", r.abort_connection, 0, 3),
        ("halt", r.halt, 1, 4),
    )
    for key, value, low, high in checks:
        if not low <= value <= high:
            raise ConfigError(f"{t.where} {key} = {value}: must be {low}..{high}")
    t.done()
    return r


def _manufacturer(t: Table) -> tuple[ManufacturerObject, ...]:
    out = []
    for key in list(t.data):
        index = _hex(key, f"{t.where} {key}")
        if not 0x2000 <= index <= 0x5FFF:
            raise ConfigError(f"{t.where} {key}: manufacturer objects are 0x2000-0x5FFF")
        e = t.sub(key)
        obj = ManufacturerObject(
            index, e.get("name", str, ""), e.get("role", str, ""), e.get("harmful", bool, False)
        )
        if obj.role not in ROLES:
            raise ConfigError(
                f"{e.where} role = {obj.role!r}: known roles: {', '.join(r for r in ROLES if r)}"
            )
        e.done()
        out.append(obj)
    t.done()
    return tuple(out)


def _modes(t: Table) -> tuple[tuple[Mode, ...], str]:
    names = t.get("supported", list, [])
    csp_enable = t.get("csp_enable", str, "target")
    t.done()
    if csp_enable not in ("target", "hold"):
        raise ConfigError(f'{t.where} csp_enable = {csp_enable!r}: "target" or "hold"')
    unknown = [n for n in names if n not in PROFILE_MODES]
    if unknown:
        raise ConfigError(
            f"{t.where} supported: unknown mode(s) {unknown}; known: {', '.join(PROFILE_MODES)}"
        )
    return tuple(PROFILE_MODES[n] for n in names), csp_enable


def load_profile(path: str | Path) -> DeviceProfile:
    """The profile in the TOML file ``path``; ConfigError naming the file and the key on any defect.

    Parameters
    ----------
    path : str | Path
        The profile's TOML file.

    Returns
    -------
    DeviceProfile
        The profile.

    Raises
    ------
    ConfigError
        If it cannot be read, or a key is unknown, of a wrong type or out of range.
    """
    p = Path(path)
    top = Table(read_toml(p, what="device profile"), p)
    device = top.sub("device")
    name = device.get("name", str, p.stem)
    eds_name = device.get("eds", str)
    if not eds_name:
        raise ConfigError(f"{p} [device] eds: the EDS/DCF file of the drive must be named")
    physics = top.sub("physics")
    params = dict(physics.get("params", dict, {}))
    physics.done()
    preset = device.get("physics", str, "dc-servo")
    from plant_emulator.preset_params import preset_params

    try:
        preset_params(preset, params)
    except ValueError as exc:
        raise ConfigError(f"{p} [physics.params]: {exc}") from None
    modes, csp_enable = _modes(top.sub("modes"))
    homing = top.sub("homing")
    methods = tuple(homing.get("methods", list, [35, 37]))
    profile = DeviceProfile(
        name=name,
        description=device.get("description", str, ""),
        modelled_on=device.get("modelled_on", str, ""),
        eds=(p.parent / eds_name).resolve(),
        source=p,
        physics=preset,
        params=params,
        node_id=device.get("node_id", int, 1),
        axes=device.get("axes", int, 1),
        modes=modes,
        csp_enable=csp_enable,
        mapping=_pdo_mapping(top.sub("pdo")),
        units=_units(top.sub("units")),
        timing=_timing(top.sub("timing")),
        reactions=_reactions(top.sub("reactions")),
        homing=Homing(methods, _finite(homing, "switch_position", 0.5)),
        manufacturer=_manufacturer(top.sub("manufacturer")),
        emcy=_emcy(top.sub("emcy")),
    )
    homing.done()
    device.done()
    top.done()
    if not 1 <= profile.node_id <= 127:
        raise ConfigError(f"{p} [device] node_id = {profile.node_id}: must be 1..127")
    if not 1 <= profile.axes <= MAX_AXES:
        raise ConfigError(f"{p} [device] axes = {profile.axes}: must be 1..{MAX_AXES}")
    return profile


def _finite(t: Table, key: str, default: float) -> float:
    value = float(t.get(key, float, default))
    if not math.isfinite(value):
        raise ConfigError(f"{t.where} {key} = {value!r}: must be finite")
    return value


def _pdo_mapping(t: Table) -> str:
    mapping = t.get("mapping", str, "remappable")
    t.done()
    if mapping not in ("remappable", "fixed"):
        raise ConfigError(f"{t.where} mapping = {mapping!r}: remappable or fixed")
    return str(mapping)


def _timing(t: Table) -> Timing:
    timing = Timing(*(_nonnegative(t, k, 0.0) for k in ("sdo_response", "pdo_latency", "mode_switch")))
    t.done()
    return timing


def _emcy(t: Table) -> dict[int, str]:
    out = {_hex(k, f"{t.where} {k}"): t.get(k, str) for k in list(t.data)}
    t.done()
    return out


def default_profile(eds: Path) -> DeviceProfile:
    """A profile for an EDS alone: the defaults of every key (the EDS must have 0x6502 and 0x608F).

    Parameters
    ----------
    eds : Path
        The EDS.

    Returns
    -------
    DeviceProfile
        Its profile.

    Raises
    ------
    ConfigError
        If the EDS lacks 0x6502 or 0x608F.
    """
    if not eds.exists():
        raise ConfigError(f"{eds}: no such EDS/DCF file")
    return DeviceProfile(
        name=eds.stem,
        description=f"{eds.name} with the default profile",
        eds=eds.resolve(),
        source=eds,
    )


def zoo() -> dict[str, Path]:
    """The shipped profiles: name -> TOML file.

    Returns
    -------
    dict[str, Path]
        Name -> TOML file.
    """
    return {p.stem: p for p in sorted(DEVICES_DIR.glob("*.toml"))}


def device_profile(name_or_path: str | Path) -> DeviceProfile:
    """A shipped profile by name, or a profile file by path; ConfigError naming the known ones.

    Parameters
    ----------
    name_or_path : str | Path
        A shipped profile's name, or a profile's file.

    Returns
    -------
    DeviceProfile
        The profile.

    Raises
    ------
    ConfigError
        If no such profile exists (the known ones named), or it is wrong (``load_profile``).
    """
    profiles = zoo()
    if str(name_or_path) in profiles:
        return load_profile(profiles[str(name_or_path)])
    p = Path(name_or_path)
    if p.suffix == ".toml":
        return load_profile(p)
    raise ConfigError(f"unknown device profile {str(name_or_path)!r}; known: {', '.join(profiles)}")
