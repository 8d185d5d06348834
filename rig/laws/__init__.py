"""Control laws the host loop runs, by name: a lazy registry like python-can's interface table.

``LAWS`` maps a ``[controller] kind`` to (module, class); the module is imported
when a law of that kind is built. ``make_law`` types the ``[controller]``
parameters against the law's ``Params`` (the loop period fills ``dt``/``ts``).
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from typing import Any

from drivers.errors import ConfigError
from rig.config_checks import require_finite
from rig.laws.base import Law, LawStep, Reference
from rig.params import build

__all__ = ["LAWS", "Law", "LawStep", "Reference", "law_class", "make_law"]

LAWS: dict[str, tuple[str, str]] = {
    "position-servo": ("rig.laws.position_servo", "PositionServoLaw"),
    "pi-speed": ("rig.laws.speed", "PiSpeedLaw"),
    "idtsm-speed": ("rig.laws.speed", "IdtsmSpeedLaw"),
    "cascade-position": ("rig.laws.cascade", "CascadePositionLaw"),
    "dq-current": ("rig.laws.dq_current", "DqCurrentLaw"),
    "speed-reference": ("rig.laws.open_loop", "SpeedReferenceLaw"),
    "position-reference": ("rig.laws.open_loop", "PositionReferenceLaw"),
    "replay": ("rig.laws.open_loop", "ReplayLaw"),
    "excited-speed": ("rig.laws.excited", "ExcitedSpeedLaw"),
}


def law_class(kind: str, source: str = "") -> type[Law]:
    """The law class of ``kind``; ConfigError naming the known kinds."""
    try:
        module, name = LAWS[kind]
    except KeyError:
        raise ConfigError(f"{source}: [controller] kind = {kind!r}; known: {', '.join(LAWS)}") from None
    cls: type[Law] = getattr(importlib.import_module(module), name)
    return cls


def make_law(
    kind: str,
    params: Mapping[str, Any],
    *,
    period: float,
    reference: Reference,
    source: str = "",
    origin: str = "start",
) -> Law:
    """Build the law ``kind`` with ``params`` (typed against its Params) at ``period`` [s]; a
    position reference's ``origin`` ("start" or "zero", ``Law.begin``)."""
    cls = law_class(kind, source)
    names = {f.name for f in dataclasses.fields(cls.Params)}
    fixed = {k: period for k in ("dt", "ts") if k in names}
    where = f"{source}: [controller] {kind}"
    require_finite(where, params)
    typed = build(cls.Params, params, where, **fixed)
    try:
        law = cls(typed, period=period, reference=reference)
    except ValueError as exc:
        raise ConfigError(f"{where}: {exc}") from exc
    law.origin = origin
    return law
