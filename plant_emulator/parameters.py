"""Preset parameters by name: typed values checked against a frozen dataclass's keys.

A preset's parameters are the keys of its dataclass (``drivers.schema.key``: type, unit,
range, meaning). The host turns text (``--param NAME=VALUE``, configuration files) into
typed values with its own parser and checks them against the same keys (``rig.params``);
the emulator checks what it is given by name: ``with_params(schema, params)`` builds
``schema`` from ``{name: value}``, and an unknown name, a value of the wrong type (a str for
a float; an int is fine for a float) or out of its key's range is a ValueError naming it.
A built dataclass is taken as it is. Rules between keys are the dataclasses' ``__post_init__``
(``require_nodes``: distinct node ids).
"""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from drivers.profiles import Profile, parse_profile
from drivers.schema import Refused, check_given, field_types, key

__all__ = ["NODE", "load_torque", "node_key", "profile_text", "require_nodes", "with_params"]

T = TypeVar("T")
PREFIX = "plant."  #: ``plant.a_m`` and ``a_m`` name the same parameter


class _Mismatch(Exception):
    """The value is not of the field's type."""


def _typed(kind: Any, value: object) -> object:
    """``value`` as a ``kind`` (int -> float widened); _Mismatch if it is not one."""
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is not type(None):
                try:
                    return _typed(arg, value)
                except _Mismatch:
                    pass
        raise _Mismatch
    if origin is typing.Literal:
        if any(type(value) is type(a) and value == a for a in args):
            return value
        raise _Mismatch
    if isinstance(value, bool) and kind is not bool:
        raise _Mismatch  # True is an int to Python, never a number to a user
    if kind is float and isinstance(value, (int, float)):
        return float(value)
    if isinstance(kind, type) and isinstance(value, kind):
        return value
    raise _Mismatch


def _name(kind: Any) -> str:
    """``kind`` as the error message says it."""
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in args)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_name(a) for a in args)
    return "None" if kind is type(None) else getattr(kind, "__name__", str(kind))


def with_params(schema: type[T], params: Mapping[str, object] | T | None) -> T:
    """``schema`` with the fields named in ``params`` set (or ``params`` itself, a built ``schema``);
    ValueError naming a bad name or value.

    Parameters
    ----------
    schema : type[T]
        A parameter dataclass.
    params : Mapping[str, object] | T | None
        Values by name, or a ``schema`` built already (None: the defaults).

    Returns
    -------
    T
        The parameters.

    Raises
    ------
    ValueError
        If a name is unknown or a value is refused (it named).
    """
    if isinstance(params, schema):
        return params
    kinds = field_types(schema)
    values: dict[str, object] = {}
    for given, value in dict(params or {}).items():  # type: ignore[arg-type]
        name = given.removeprefix(PREFIX)
        if name not in kinds:
            raise ValueError(f"preset parameter {given!r} unknown; known: {', '.join(kinds)}")
        try:
            values[name] = _typed(kinds[name], value)
        except _Mismatch:
            raise ValueError(
                f"preset parameter {name}={value!r}: expected {_name(kinds[name])}, "
                f"got {type(value).__name__}"
            ) from None
    check_given(schema, values)
    return schema(**values)


NODE = (1, 127)  #: CANopen node ids


def node_key(default: int, doc: str) -> Any:
    """A node-id key (1..127).

    Parameters
    ----------
    default : int
        The node-ID.
    doc : str
        What the node is.

    Returns
    -------
    Any
        The dataclass field (``drivers.schema.key``).
    """
    return key(default, "", doc, ge=NODE[0], le=NODE[1])


def require_nodes(obj: object, *names: str) -> None:
    """The named node-id fields are distinct; ``Refused`` naming the field and value.

    Parameters
    ----------
    obj : object
        The parameters.
    *names : str
        Fields holding node-IDs.

    Raises
    ------
    Refused
        If two of them are equal (the field and value named).
    """
    seen: dict[int, str] = {}
    for name in names:
        value = getattr(obj, name)
        if value in seen:
            raise Refused(name, value, f"is also {seen[value]}: give each device its own node id")
        seen[value] = name


def profile_text(text: str) -> None:
    """``text`` is a load torque profile of ``drivers.profiles`` (or ``none``); ValueError.

    Parameters
    ----------
    text : str
        A profile (``drivers.profiles``) or ``none``.
    """
    parse_profile(text)


def load_torque(text: str) -> Profile | None:
    """The load torque [N m] of time [s] written in ``text`` (``parse_profile``); None for ``none``.

    Parameters
    ----------
    text : str
        A profile (``drivers.profiles``) or ``none``.

    Returns
    -------
    Profile | None
        [N m] of time [s]; None for ``none``.
    """
    profile = parse_profile(text)
    return None if text.strip() == "none" else profile
