"""The one typed NAME=VALUE parser: every table, ``--param`` and ``--fault`` goes through it.

``typed_values(schema, items, source)`` checks names against the keys of a
dataclass ``schema`` (``drivers.schema.keys``), converts each value to the
field's type, and checks it against its key's rule (``drivers.schema.Key``):

- values that already have a type (from TOML) are checked: an int is a float,
  a bool is never a number, a list is a tuple, and a string is only a string
  (``period = "0"`` is an error, not a period);
- with ``text=True`` (``--param`` and the like, from the command line) text is
  parsed: ``int`` (``0x`` allowed), ``float`` (a fraction such as ``1/27``
  allowed), ``bool`` (true/false, yes/no, on/off, 1/0), ``str``, a ``Literal``
  of choices, a tuple of floats (``1,2``), a tuple of tuples of floats
  (row-major ``1,0;0,1``), and ``X | None`` (``none``).

An unknown name or a bad value is a ``ConfigError`` naming the item, where it
came from (``source``: a file and table, or an option) and what is expected:
``<source>: NAME = VALUE: expected TYPE`` for a value of the wrong type,
``<source> NAME = VALUE: must be RULE`` for one out of its key's range.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Iterable, Mapping
from typing import Any

from drivers.errors import ConfigError
from drivers.schema import Refused, check_given, field_types, key_of, keys

__all__ = ["build", "field_types", "parse_items", "required", "typed_values"]

_TRUE, _FALSE = ("true", "yes", "on", "1"), ("false", "no", "off", "0")


def parse_items(items: Iterable[str], source: str) -> dict[str, str]:
    """``["NAME=VALUE", ...]`` -> {NAME: VALUE}; ConfigError naming a malformed item.

    Parameters
    ----------
    items : Iterable[str]
        ``NAME=VALUE`` strings.
    source : str
        Named in errors (the option).

    Returns
    -------
    dict[str, str]
        NAME -> VALUE.

    Raises
    ------
    ConfigError
        If an item has no ``=`` or no name.
    """
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise ConfigError(f"{source} {item!r}: expected NAME=VALUE")
        out[name.strip()] = value.strip()
    return out


class _Expected(ValueError):
    """The value is not of the kind; the message says what is expected."""


def _number(text: str) -> float:
    num, slash, den = text.partition("/")
    return float(num) / float(den) if slash else float(num)


def _convert(kind: Any, value: Any, text: bool) -> Any:
    """``value`` as ``kind`` (parsed from a string where ``text``); ValueError with what is expected."""
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin in (typing.Union, types.UnionType):
        if value is None or (text and isinstance(value, str) and value.lower() == "none"):
            if type(None) in args:
                return None
        inner = [a for a in args if a is not type(None)]
        return _convert(inner[0], value, text)
    if origin is typing.Literal:
        if value not in args:
            raise _Expected(f"one of {', '.join(map(str, args))}")
        return value
    if origin is tuple:
        if text and isinstance(value, str):
            value = [row.split(",") for row in value.split(";")] if ";" in value else value.split(",")
        if not isinstance(value, (list, tuple)):
            raise _Expected("a list")
        element: Any = args[0] if args else float
        return tuple(_convert(element, v, text) for v in value)
    if kind is bool:
        if text and isinstance(value, str) and value.lower() in _TRUE + _FALSE:
            return value.lower() in _TRUE
        if not isinstance(value, bool):
            raise _Expected("true or false")
        return value
    if kind is int:
        if text and isinstance(value, str):
            return int(value, 0)
        if isinstance(value, bool) or not isinstance(value, int):
            raise _Expected("int, not a string" if isinstance(value, str) else "an integer")
        return value
    if kind is float:
        if text and isinstance(value, str):
            value = _number(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Expected("float, not a string" if isinstance(value, str) else "a number")
        if math.isnan(value):
            raise _Expected("a number, not NaN")
        return float(value)
    if kind is str:
        if not isinstance(value, str):
            raise _Expected("a string")
        return value
    raise _Expected(f"a {kind}")  # pragma: no cover - a schema with an unsupported field type


def _expected(kind: Any) -> str:
    if typing.get_origin(kind) is typing.Literal:
        return "one of " + ", ".join(map(str, typing.get_args(kind)))
    return getattr(kind, "__name__", str(kind))


def typed_values(
    schema: type,
    items: Mapping[str, Any],
    source: str,
    *,
    aliases: Mapping[str, str] | None = None,
    fixed: Iterable[str] = (),
    text: bool = False,
) -> dict[str, Any]:
    """``items`` converted to the field types of dataclass ``schema`` (see the module docstring).

    ``aliases`` maps other spellings to field names; ``fixed`` names fields the caller
    sets itself (giving one is an error too); ``text``: the values are command-line text.

    Parameters
    ----------
    schema : type
        A dataclass.
    items : Mapping[str, Any]
        Key -> value (text, or TOML's).
    source : str
        Named in errors.
    aliases : Mapping[str, str] | None, optional
        Other spellings -> field names.
    fixed : Iterable[str], optional
        Fields the caller sets, refused here.
    text : bool, optional
        The values are command-line text.

    Returns
    -------
    dict[str, Any]
        Field -> typed value.

    Raises
    ------
    ConfigError
        If a key is unknown or fixed, or a value not of its type.
    """
    hints = field_types(schema)
    kinds = {k: hints[k] for k in keys(schema)}
    settable = {k: v for k, v in kinds.items() if k not in set(fixed)}
    out: dict[str, Any] = {}
    for given, value in items.items():
        name = (aliases or {}).get(given, given)
        if name not in settable:
            raise ConfigError(f"{source}: unknown parameter {given!r}; known: {', '.join(settable)}")
        try:
            out[name] = _convert(settable[name], value, text)
        except (ValueError, ZeroDivisionError, TypeError) as exc:
            expected = str(exc) if isinstance(exc, _Expected) else _expected(settable[name])
            raise ConfigError(f"{source}: {given} = {value!r}: expected {expected}") from None
    try:
        check_given(schema, out)
    except Refused as exc:
        raise ConfigError(f"{source} {exc}") from None
    return out


def required(schema: type, values: Mapping[str, Any], source: str, fixed: Iterable[str] = ()) -> None:
    """ConfigError naming the first key of ``schema`` without a default that ``values`` lacks.

    Parameters
    ----------
    schema : type
        A dataclass.
    values : Mapping[str, Any]
        Field -> value.
    source : str
        Named in errors.
    fixed : Iterable[str], optional
        Fields the caller sets.

    Raises
    ------
    ConfigError
        Naming the first key without a default that ``values`` lacks.
    """
    for name, f in keys(schema).items():
        no_default = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if no_default and name not in values and name not in set(fixed):
            spec = key_of(f)
            what = f" ({spec.doc})" if spec is not None and spec.doc else ""
            raise ConfigError(f"{source}: {name} is missing{what}")


def build(schema: type, items: Mapping[str, Any], source: str, **fixed: Any) -> Any:
    """``schema(**typed_values(...), **fixed)``, every key without a default given; a rule between
    keys the dataclass refuses (``Refused``, ValueError) becomes a ConfigError naming ``source``.

    Parameters
    ----------
    schema : type
        A dataclass.
    items : Mapping[str, Any]
        Key -> value.
    source : str
        Named in errors.
    **fixed : Any
        Fields the caller sets.

    Returns
    -------
    Any
        The dataclass built.

    Raises
    ------
    ConfigError
        If a value or a rule between keys is refused.
    """
    values = typed_values(schema, items, source, fixed=fixed)
    required(schema, values, source, fixed)
    try:
        return schema(**values, **fixed)
    except Refused as exc:
        raise ConfigError(f"{source} {exc}") from None
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{source}: {exc}") from exc
