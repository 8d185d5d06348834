"""Control laws the host loop runs, by name: a lazy registry like python-can's interface table.

``LAWS`` maps a ``[controller] kind`` to (module, class); the module is imported
when a law of that kind is built. Each law's ``Params`` declares its ``[controller]`` keys
(``drivers.schema.key``), checked when the configuration is loaded; ``make_law`` builds it.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from drivers.errors import ConfigError
from rig.laws.base import Law, LawParams, LawStep, Reference

__all__ = ["LAWS", "Law", "LawParams", "LawStep", "Reference", "law_class", "make_law"]

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
    """The law class of ``kind``; ConfigError naming the known kinds.

    Parameters
    ----------
    kind : str
        ``[controller] kind``.
    source : str, optional
        Named in the error.

    Returns
    -------
    type[Law]
        The law's class.

    Raises
    ------
    ConfigError
        If ``kind`` is unknown (the known ones named).
    """
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
    origin: str = "start",
) -> Law:
    """The law ``kind`` with ``params`` (its ``Params``' keys, checked when the configuration was
    loaded: ``rig.config.controller``) at ``period`` [s]; a position reference's ``origin``
    ("start" or "zero", ``Law.begin``).

    Parameters
    ----------
    kind : str
        ``[controller] kind``.
    params : Mapping[str, Any]
        Its parameters, checked already.
    period : float
        [s] the loop's.
    reference : Reference
        The reference.
    origin : str, optional
        "start" or "zero" (a position reference's).

    Returns
    -------
    Law
        The law.
    """
    cls = law_class(kind)
    law = cls(cls.Params(**params), period=period, reference=reference)
    law.origin = origin
    return law
