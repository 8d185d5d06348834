"""Loading a rig configuration: ``load_config(path)`` reads the TOML file, ``rig_config(doc,
source)`` checks a parsed document, every table of ``rig.config.schema`` (``[controller]`` by
``rig.config.controller``, ``[emulator]`` by ``rig.config.emulator``) and the rules between them
(``rig.config.rules``), in one pass. Apart from the tables' module, so that those modules import
the schema and the schema none of them.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from drivers.files import read_toml
from rig.config.axes import axis_config
from rig.config.controller import controller_config
from rig.config.emulator import emulator_config
from rig.config.params import typed_values
from rig.config.rules import check_rig
from rig.config.schema import TABLES, Override, RigConfig, resolved_period, table

__all__ = ["load_config", "rig_config"]

_OLD_FORM = (
    "is the old single-drive form: describe each device as an [[axis]] table (name, kind, node_id, mode, "
    "[axis.limits]) and name the axes in [controller] reads and commands "
    "(see examples/dc_servo_position.toml)"
)


def _section(doc: dict[str, Any], name: str, source: str, overrides: Iterable[Override]) -> Any:
    cls = TABLES[name]
    values = typed_values(cls, table(source, f"[{name}]", doc.get(name, {})), f"{source}: [{name}]")
    for o in overrides:
        if o.table == name:
            values.update(typed_values(cls, o.items, o.source, text=o.text))
    return cls(**values)


def rig_config(doc: dict[str, Any], source: str, overrides: Iterable[Override] = ()) -> RigConfig:
    """The checked configuration of a parsed TOML document (``source`` names it in errors), with
    ``overrides`` applied (``rig.config.schema``'s docstring).

    Parameters
    ----------
    doc : dict[str, Any]
        The parsed TOML document.
    source : str
        Named in errors (the file).
    overrides : Iterable[Override], optional
        Values given beside the file.

    Returns
    -------
    RigConfig
        The configuration.

    Raises
    ------
    ConfigError
        At the first defect (file, table, key and value named).
    """
    overrides = tuple(overrides)
    for old in ("drive", "limits"):
        if old in doc:
            raise ConfigError(f"{source}: [{old}] {_OLD_FORM}")
    known = {*TABLES, "emulator", "axis", "controller"}
    for name in doc:
        if name not in known:
            raise ConfigError(f"{source}: unknown section [{name}]; known: {', '.join(sorted(known))}")
    sections = {name: _section(doc, name, source, overrides) for name in TABLES}
    raw_axes = doc.get("axis", [])
    if not isinstance(raw_axes, list) or not raw_axes:
        raise ConfigError(f"{source}: describe at least one device as an [[axis]] table")
    axes = tuple(axis_config(source, n, t) for n, t in enumerate(raw_axes))
    if "controller" not in doc:
        raise ConfigError(f"{source}: [controller] is missing: name the law (kind) and its axes")
    emulator = emulator_config(source, table(source, "[emulator]", doc.get("emulator", {})))
    period = resolved_period(sections["run"], emulator)
    controller = controller_config(source, table(source, "[controller]", doc["controller"]), axes, period)
    cfg = RigConfig(source=source, emulator=emulator, axes=axes, controller=controller, **sections)
    check_rig(cfg)
    return cfg


def load_config(path: str | Path, overrides: Iterable[Override] = ()) -> RigConfig:
    """Load and check a rig configuration file (``drivers.files.read_toml``: a regular file of at
    most ``CONFIG_LIMIT``, UTF-8, not nested deeper than ``MAX_DEPTH``), with ``overrides``.

    Parameters
    ----------
    path : str | Path
        The TOML file.
    overrides : Iterable[Override], optional
        Values given beside the file.

    Returns
    -------
    RigConfig
        The configuration.
    """
    p = Path(path)
    return rig_config(read_toml(p, what="rig configuration"), str(p), overrides)
