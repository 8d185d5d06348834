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
``ConfigError`` naming the file and the key. What a profile holds once read is
``plant_emulator.profile_model``'s (``DeviceProfile``, which checks itself against its EDS).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from drivers.files import read_toml
from drivers.maps.cia import Mode
from drivers.maps.logical import MAX_AXES
from drivers.maps.units import SiUnit
from plant_emulator.profile_model import (
    PROFILE_MODES,
    ROLES,
    DeviceProfile,
    Homing,
    ManufacturerObject,
    Reactions,
    Timing,
    Units,
)
from plant_emulator.toml_table import Table

__all__ = [
    "DEVICES_DIR",
    "DeviceProfile",
    "ManufacturerObject",
    "Units",
    "default_profile",
    "device_profile",
    "load_profile",
    "zoo",
]

DEVICES_DIR = Path(__file__).resolve().parent / "devices"


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
    preset, params = _physics(top, device, p)
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


def _physics(top: Table, device: Table, p: Path) -> tuple[str, dict[str, Any]]:
    """``[device] physics`` (the preset whose motor is behind the drive) and ``[physics.params]``,
    checked against the preset; ConfigError naming the file otherwise."""
    physics = top.sub("physics")
    params = dict(physics.get("params", dict, {}))
    physics.done()
    preset = device.get("physics", str, "dc-servo")
    from plant_emulator.preset_params import preset_params

    try:
        preset_params(preset, params)
    except ValueError as exc:
        raise ConfigError(f"{p} [physics.params]: {exc}") from None
    return preset, params


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
