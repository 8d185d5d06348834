"""The ``[emulator]`` table: the preset or the drive's twin behind ``--emulate``, and its parameters.

``emulator_config(path, table)`` checks it when the file is loaded: ``preset`` names one of
``plant_emulator.presets.PRESETS`` or ``device`` a twin (a zoo profile's name or a profile
file, read now); ``[emulator.params]`` are keys of that preset's dataclass (``a_m`` or
``plant.a_m``; over a twin's own values), checked by their type and range and then by the
preset's rules between keys as it is built; ``[emulator.inverter]`` are keys of
``plant_emulator.inverter_model.InverterModel``. The built preset is kept (``physics``): the
emulated world is made from it without another check.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drivers.errors import ConfigError
from drivers.schema import Refused, keys
from rig.config.params import typed_values

if TYPE_CHECKING:
    from plant_emulator.device_profile import DeviceProfile

__all__ = ["emulator_config", "inverter_values", "physics", "preset_params"]

_KNOWN = ("preset", "device", "params", "inverter")


def physics(
    name: str,
    items: Mapping[str, Any],
    source: str,
    *,
    text: bool = False,
    base: Mapping[str, Any] | None = None,
) -> tuple[dict[str, Any], Any]:
    """(``items`` typed and checked, the preset ``name`` built with them over ``base``, a twin's own
    values); ``text``: command-line text. ConfigError naming ``source``, the key and the value.

    Parameters
    ----------
    name : str
        The preset.
    items : Mapping[str, Any]
        Its values by key.
    source : str
        Named in errors (a file's table, an option).
    text : bool, optional
        The values are command-line text.
    base : Mapping[str, Any] | None, optional
        A twin's own values, under ``items``.

    Returns
    -------
    tuple[dict[str, Any], Any]
        (``items`` typed and checked, the preset's dataclass built).

    Raises
    ------
    ConfigError
        If a key is unknown or a value refused (``source``, key and value named).
    """
    from plant_emulator.presets import PRESETS

    if name not in PRESETS:
        raise ConfigError(f"{source}: unknown preset {name!r}; known: {', '.join(PRESETS)}")
    schema = PRESETS[name]
    aliases = {f"plant.{k}": k for k in keys(schema)}
    typed = typed_values(schema, items, source, aliases=aliases, text=text)
    try:
        return typed, schema(**{**(base or {}), **typed})
    except Refused as exc:
        raise ConfigError(f"{source} {exc}") from None
    except ValueError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def preset_params(
    name: str,
    params: Mapping[str, Any],
    source: str,
    *,
    text: bool = False,
    base: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """``params`` of preset ``name`` typed and checked (see ``physics``).

    Parameters
    ----------
    name : str
        The preset.
    params : Mapping[str, Any]
        Its values by key.
    source : str
        Named in errors.
    text : bool, optional
        The values are command-line text.
    base : Mapping[str, Any] | None, optional
        A twin's own values, under ``params``.

    Returns
    -------
    dict[str, Any]
        ``params`` typed and checked.
    """
    return physics(name, params, source, text=text, base=base)[0]


def inverter_values(items: Mapping[str, Any], source: str, *, text: bool = False) -> dict[str, Any]:
    """The emulated Modbus inverter's parameters ``items`` typed and checked (its keys).

    Parameters
    ----------
    items : Mapping[str, Any]
        ``[emulator.inverter]`` values by key.
    source : str
        Named in errors.
    text : bool, optional
        The values are command-line text.

    Returns
    -------
    dict[str, Any]
        The values, typed and checked.
    """
    if not items:  # nothing to check: a run on a real bus loads no emulator
        return {}
    from plant_emulator.inverter_model import InverterModel

    return typed_values(InverterModel, items, source, text=text)


def _table(path: str, where: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: {where} must be a table")
    return value


def emulator_config(path: str, table: dict[str, Any]) -> Any:
    """The checked ``EmulatorConfig`` of ``table`` in file ``path`` (see the module docstring).

    Parameters
    ----------
    path : str
        The file, named in errors.
    table : dict[str, Any]
        ``[emulator]``.

    Returns
    -------
    Any
        The ``EmulatorConfig``.

    Raises
    ------
    ConfigError
        If a key is unknown, of a wrong type or refused.
    """
    from rig.config.schema import EmulatorConfig

    preset, device = _preset_or_device(path, table)
    params = _table(path, "[emulator.params]", table.get("params", {}))
    inverter = inverter_values(
        _table(path, "[emulator.inverter]", table.get("inverter", {})), f"{path}: [emulator.inverter]"
    )
    if not (preset or device):
        if params:
            raise ConfigError(
                f"{path}: [emulator.params] {', '.join(params)}: name the [emulator] preset or device"
            )
        return EmulatorConfig("", "", {}, inverter)
    profile = _device_profile(path, device) if device else None
    from plant_emulator.presets import PRESETS

    name = profile.physics if profile else preset
    if name not in PRESETS:
        raise ConfigError(f"{path}: [emulator] preset = {name!r}: unknown; known: {', '.join(PRESETS)}")
    what = f"device {device}" if device else f"preset {name}"
    base = profile.params if profile else None
    typed, built = physics(name, params, f"{path}: [emulator.params] of {what}", base=base)
    emulator = EmulatorConfig(preset, device, typed, inverter)
    emulator.__dict__.update(profile=profile, physics=built)  # its cached properties: read and built here
    return emulator


def _preset_or_device(path: str, table: dict[str, Any]) -> tuple[str, str]:
    """``[emulator]``'s keys checked, and its (preset, device), one of them or neither given; a
    relative device file is taken from ``path``'s folder."""
    unknown = set(table) - set(_KNOWN)
    if unknown:
        raise ConfigError(
            f"{path}: unknown key(s) {sorted(unknown)} in [emulator]; known: {', '.join(_KNOWN)}"
        )
    preset, device = table.get("preset", ""), table.get("device", "")
    for key, value in (("preset", preset), ("device", device)):
        if not isinstance(value, str):
            raise ConfigError(f"{path}: [emulator] {key} = {value!r}: expected a string")
    if preset and device:
        raise ConfigError(f"{path}: [emulator] has both preset and device: give one")
    if device.endswith(".toml") and not Path(device).is_absolute():
        device = str(Path(path).parent / device)
    return preset, device


def _device_profile(path: str, device: str) -> DeviceProfile:
    """The device profile ``device`` names (a zoo twin or a file), its errors prefixed with where."""
    from plant_emulator.device_profile import device_profile

    try:
        return device_profile(device)
    except ConfigError as exc:
        raise ConfigError(f"{path}: [emulator] device = {device!r}: {exc}") from None
