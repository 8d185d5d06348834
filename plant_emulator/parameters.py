"""Preset parameters by name: typed values checked against a frozen dataclass, and range checks.

The host turns text (``--param NAME=VALUE``, configuration files) into typed
values with its own parser, from the same field types
(``typing.get_type_hints``); the emulator only checks what it is given.
``with_params(schema, params)`` builds ``schema`` from ``{name: value}``: an
unknown name, or a value of the wrong type (a str for a float; an int is fine
for a float), is a ValueError naming it. The dataclasses check ranges in
``__post_init__`` with ``require_positive``/``require_nonnegative``/``require_nodes``.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from drivers.maps.cia import NODE_IDS
from plant_emulator.profiles import Profile, parse_profile

__all__ = [
    "field_types",
    "load_torque",
    "require_fits",
    "require_nodes",
    "require_nonnegative",
    "require_positive",
    "with_params",
]

T = TypeVar("T")
PREFIX = "plant."  #: ``plant.a_m`` and ``a_m`` name the same parameter


class _Mismatch(Exception):
    """The value is not of the field's type."""


def field_types(schema: type) -> dict[str, Any]:
    """The fields of dataclass ``schema`` with their resolved types."""
    hints = typing.get_type_hints(schema)
    return {f.name: hints[f.name] for f in dataclasses.fields(schema)}


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


def with_params(schema: type[T], params: Mapping[str, object] | None) -> T:
    """``schema`` with the fields named in ``params`` set; ValueError naming a bad name or value."""
    kinds = field_types(schema)
    values: dict[str, object] = {}
    for given, value in (params or {}).items():
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
    return schema(**values)


def require_positive(obj: object, *names: str) -> None:
    """Each named field is a finite number > 0; ValueError naming the field and value."""
    for name in names:
        value = getattr(obj, name)
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"preset parameter {name} must be > 0, got {value!r}")


def require_nonnegative(obj: object, *names: str) -> None:
    """Each named field is a finite number >= 0; ValueError naming the field and value."""
    for name in names:
        value = getattr(obj, name)
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"preset parameter {name} must be >= 0, got {value!r}")


#: the largest value of the objects the integer parameters go to (0x6073 per mille is 16 bits,
#: 0x6080 rpm 32 bits, 0x608F increments per revolution give 32-bit signed positions)
OBJECT_RANGE = {"_permille": 0xFFFF, "_rpm": 0xFFFF_FFFF, "counts_per_rev": 0x7FFF_FFFF}


def require_fits(obj: object) -> None:
    """Each integer field named as in ``OBJECT_RANGE`` fits its object; ValueError naming it."""
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        high = next((h for end, h in OBJECT_RANGE.items() if f.name.endswith(end)), None)
        if high is not None and isinstance(value, int) and value > high:
            raise ValueError(f"preset parameter {f.name} must be <= {high}, got {value!r}")


def require_nodes(obj: object, *names: str) -> None:
    """The named node-id fields are in 1..127 and distinct; ValueError naming the field and value."""
    seen: dict[int, str] = {}
    for name in names:
        value = getattr(obj, name)
        if value not in NODE_IDS:
            raise ValueError(f"preset parameter {name} must be a node id 1..127, got {value!r}")
        if value in seen:
            raise ValueError(f"preset parameter {name}={value} is also {seen[value]}")
        seen[value] = name


def load_torque(text: str) -> Profile | None:
    """The load torque [N m] of time [s] written in ``text`` (``parse_profile``); None for ``none``.

    ValueError naming the parameter ``load`` and the faulty term.
    """
    try:
        profile = parse_profile(text)
    except ValueError as exc:
        raise ValueError(f"preset parameter load={text!r}: {exc}") from None
    return None if text.strip() == "none" else profile
