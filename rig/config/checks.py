"""What a value of a rig configuration must be, where bounds do not say it: formats and limits.

The ranges of single keys are data of their fields (``drivers.schema.key``); the formats
here are their ``check`` functions (a run name, an output folder's path, a python-can
interface, a Modbus register map, a time profile), each raising ValueError with the rule. The
rules between keys and tables are ``rig.config.rules``'. ``require_limits`` is apart: ``rig run``
refuses a commanded axis without any limit unless ``--no-limits`` is given.
"""

from __future__ import annotations

import math
from typing import Any

from drivers.errors import ConfigError
from drivers.schema import MAX_PERIOD, MIN_PERIOD

__all__ = [
    "MAX_HEARTBEAT",
    "MAX_LATENCY",
    "MAX_PERIOD",
    "MIN_PERIOD",
    "PERIOD_RULE",
    "interface",
    "output_path",
    "profile",
    "register_map",
    "require_limits",
    "run_name",
]

MAX_HEARTBEAT = 65.535  #: [s] heartbeat times are 16-bit milliseconds (0x1016, 0x1017)
MAX_LATENCY = 0xFFFF_FFFF * 1e-6  #: [s] the drive's command latency 0x2001 is 32-bit microseconds
INT32 = 0x7FFF_FFFF
PERIOD_RULE = f"a period of {MIN_PERIOD:g} .. {MAX_PERIOD:g} s"


def run_name(name: str) -> None:
    """A run name is a plain file name: its directory ``<output>/<name>-<time>`` stays in output.

    Parameters
    ----------
    name : str
        ``[run] name``.

    Raises
    ------
    ValueError
        If it is not a plain file name.
    """
    plain = (
        bool(name)
        and name not in (".", "..")
        and not any(c in "/\\" or ord(c) < 32 or c == "\x7f" for c in name)
        and len(name.encode("utf-8", "replace")) <= 200
    )
    if not plain:
        raise ValueError(
            "must be a plain name (no / or \\, no '..', no control characters, at most 200 bytes)"
        )


def output_path(output: str) -> None:
    """A folder's path: not empty, no NUL.

    Parameters
    ----------
    output : str
        ``[run] output``.

    Raises
    ------
    ValueError
        If it is empty or holds a NUL.
    """
    if not output or "\0" in output:
        raise ValueError("must be a folder's path")


def interface(name: str) -> None:
    """A python-can interface (python-can is imported only to check it).

    Parameters
    ----------
    name : str
        ``[bus] interface``.

    Raises
    ------
    ValueError
        If python-can does not know it.
    """
    from drivers.bus import check_interface

    try:
        check_interface(name, "")
    except ConfigError as exc:
        raise ValueError(str(exc).split(": ", 1)[1]) from None


def register_map(name: str) -> None:
    """A Modbus register map of ``drivers.maps`` (abb-drives-profile, delta-vfd-b).

    Parameters
    ----------
    name : str
        ``[[axis]] map``.
    """
    from drivers.maps import modbus_map

    modbus_map(name)


def profile(text: str) -> None:
    """A time profile of ``drivers.profiles`` ("" : none).

    Parameters
    ----------
    text : str
        A profile ("": none).
    """
    if text:
        from drivers.profiles import parse_profile

        parse_profile(text)


def require_limits(cfg: Any) -> None:
    """Refuse a commanded axis (by the law or a profile) without any limit (``rig run --no-limits``).

    Parameters
    ----------
    cfg : Any
        The ``RigConfig``.

    Raises
    ------
    ConfigError
        If a commanded axis has no limit (the axis named).
    """
    commanded = {*cfg.controller.commands, *(a.name for a in cfg.axes if a.profile)}
    bare = [
        a.name
        for a in cfg.axes
        if a.name in commanded
        and all(math.isinf(getattr(a.limits, k)) for k in ("command", "speed", "current"))
        and math.isinf(a.limits.position_min)
        and math.isinf(a.limits.position_max)
    ]
    if bare:
        raise ConfigError(
            f"{cfg.source}: [[axis]] {', '.join(map(repr, bare))}: commanded without any limit: "
            "give [axis.limits] command, speed, position_min/max or current (or rig run --no-limits)"
        )
