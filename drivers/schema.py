"""Keys of a configuration table as data: the one schema the loader checks and the docs print.

A table is a dataclass; each of its keys is a field declared with ``key(default, unit, doc,
...)``, whose metadata (a ``Key``) holds the key's unit, its meaning and the values it allows:
bounds (``ge``, ``gt``, ``le``, ``lt``), ``finite`` (a number given as inf is refused; the
default may be inf, meaning none), ``nonzero``, ``also`` (values allowed outside the bounds,
each with what it means: ``{0.0: "the preset's"}``), ``check`` (a function that raises
ValueError with the rule, for a format such as a profile or a file name) and ``kinds`` (the
``[[axis]] kind`` values the key belongs to). Choices are the field's ``Literal`` type. A
table's rules between keys are code: a ``Refused`` (key, value, rule) from its ``__post_init__``
or from the loader. The type and the default are the field's own.

It lives in the lowest layer (as ``drivers.errors`` does) so that ``rig``'s tables, the control
laws' parameters and ``plant_emulator``'s presets and inverter declare their keys one way.
``controllers`` stays pure: ``rig.laws`` declares the keys of the laws it runs.

Why dataclasses and not pydantic: the tables, the laws' parameters and the presets were frozen
dataclasses already, built by the code too (``rig identify``, the sweeps, the benches); metadata
on those same fields keeps one definition of each key, where pydantic would add a second model
per table (or a dependency in ``plant_emulator`` and ``drivers``). The command line's
``NAME=VALUE`` text needs our parser anyway (``rig.params``: ``1/27``, ``0x7F``, ``1,0;0,1``),
and errors must read ``FILE: [table] key = value: must be ...`` in one line, which pydantic's
grouped messages would have to be rewritten into.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = [
    "MAX_PERIOD",
    "MIN_PERIOD",
    "Key",
    "Refused",
    "check_given",
    "field_types",
    "key",
    "key_of",
    "keys",
]

MIN_PERIOD = 1e-5  #: [s] the shortest cycle: a CAN frame alone takes 50 us at 1 Mbit/s
MAX_PERIOD = 10.0  #: [s] the longest cycle a control loop (and an emulated motor) is run at


class Refused(ValueError):
    """``key = value`` is not allowed: ``rule`` says what is (the loader adds the file and table).

    Parameters
    ----------
    key : str
        The key.
    value : Any
        The value given.
    rule : str
        What is allowed, in words.
    """

    def __init__(self, key: str, value: Any, rule: str) -> None:
        super().__init__(f"{key} = {value!r}: {rule}")
        self.key, self.value, self.rule = key, value, rule


def _g(x: float) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


@dataclass(frozen=True)
class Key:
    """What a key is and what it allows (see the module docstring)."""

    unit: str = ""  #: the key's unit ("": none)
    doc: str = ""  #: what the key means
    ge: float | None = None  #: the least value allowed (None: no bound)
    gt: float | None = None  #: values must be above it (None: no bound)
    le: float | None = None  #: the most value allowed (None: no bound)
    lt: float | None = None  #: values must be below it (None: no bound)
    finite: bool = True  #: inf and nan refused
    nonzero: bool = False  #: 0 refused
    also: tuple[tuple[Any, str], ...] = ()  #: (value, meaning) pairs allowed outside the bounds
    check: Callable[[Any], Any] | None = None  #: raises ValueError with the rule where the value is refused
    rule: str = ""  #: the rule in words, where the bounds say it badly
    kinds: tuple[str, ...] = ()  #: the ``[[axis]] kind`` values the key belongs to (): all

    def text(self) -> str:
        """The values allowed, in words: what follows "must be" (and the docs' column).

        Returns
        -------
        str
            The values allowed, in words (what follows "must be").
        """
        if self.rule:
            return self.rule
        unit = f" [{self.unit}]" if self.unit[:1].isdigit() else f" {self.unit}" if self.unit else ""
        lo = (">=", self.ge) if self.ge is not None else (">", self.gt) if self.gt is not None else None
        hi = ("<=", self.le) if self.le is not None else ("<", self.lt) if self.lt is not None else None
        if lo and hi and lo[0] == ">=" and hi[0] == "<=":
            words = f"{_g(lo[1])} .. {_g(hi[1])}{unit}"
        elif lo and hi:
            left, right = "[" if lo[0] == ">=" else "(", "]" if hi[0] == "<=" else ")"
            words = f"in {left}{_g(lo[1])}, {_g(hi[1])}{right}{unit}"
        elif lo or hi:
            op, bound = lo or hi  # type: ignore[misc]
            words = f"{op} {_g(bound)}{unit}"
        else:
            words = "a finite number" if self.finite else ""
        if self.nonzero:
            words = f"{words}, not 0" if words else "not 0"
        notes = ", ".join(f"{_g(v)}: {meaning}" for v, meaning in self.also)
        return f"{words} ({notes})" if notes and words else notes or words

    def refusal(self, value: Any, default: Any = None) -> str | None:
        """Why ``value`` is not allowed ("must be ..."), or None; a list's items each.

        Parameters
        ----------
        value : Any
            The value given.
        default : Any, optional
            The key's default (allowed whatever the rules say).

        Returns
        -------
        str | None
            Why it is refused ("must be ..."); None: allowed.
        """
        if isinstance(value, (list, tuple)):
            for item in value:
                why = self.refusal(item)
                if why:
                    return why
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return self._checked(value)
        if any(value == v for v, _ in self.also):
            return None
        if isinstance(value, float) and math.isinf(value) and self.finite:
            if self.rule:
                return f"must be {self.rule}"
            none = isinstance(default, float) and default == value
            words = self.text()
            words = "" if words == "a finite number" else f" {words}"
            return f"must be a finite number{words}" + (" (leave it out for none)" if none else "")
        bad = (
            (self.ge is not None and not value >= self.ge)
            or (self.gt is not None and not value > self.gt)
            or (self.le is not None and not value <= self.le)
            or (self.lt is not None and not value < self.lt)
            or (self.nonzero and value == 0)
        )
        return f"must be {self.text()}" if bad else self._checked(value)

    def _checked(self, value: Any) -> str | None:
        if self.check is None:
            return None
        try:
            self.check(value)
        except ValueError as exc:
            return str(exc)
        return None


def key(
    default: Any = dataclasses.MISSING,
    unit: str = "",
    doc: str = "",
    *,
    factory: Callable[[], Any] | None = None,
    also: Mapping[Any, str] | None = None,
    **allowed: Any,
) -> Any:
    """A field of a schema dataclass that is a key: ``default`` (or ``factory``), its ``unit``,
    what it means (``doc``) and what it allows (``Key``'s fields).

    Parameters
    ----------
    default : Any, optional
        The key's default.
    unit : str, optional
        Its unit.
    doc : str, optional
        What it means.
    factory : Callable[[], Any] | None, optional
        Makes the default (a mutable one).
    also : Mapping[Any, str] | None, optional
        Values allowed outside the bounds -> what they mean.
    **allowed : Any
        ``Key``'s other fields (``ge``, ``gt``, ``le``, ``lt``, ``check`` ...).

    Returns
    -------
    Any
        The dataclass field.
    """
    meta = {"key": Key(unit, doc, also=tuple((also or {}).items()), **allowed)}
    if factory is not None:
        return dataclasses.field(default_factory=factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def key_of(f: dataclasses.Field[Any]) -> Key | None:
    """The ``Key`` of field ``f`` (None: not declared with ``key``).

    Parameters
    ----------
    f : dataclasses.Field[Any]
        A dataclass field.

    Returns
    -------
    Key | None
        Its ``Key``; None: not declared with ``key``.
    """
    found: Key | None = f.metadata.get("key")
    return found


def keys(schema: Any) -> dict[str, dataclasses.Field[Any]]:
    """The settable keys of dataclass ``schema`` (a class or an instance): its fields declared
    with ``key``, or, where it declares none, every field of its ``__init__``.

    Parameters
    ----------
    schema : Any
        A dataclass, class or instance.

    Returns
    -------
    dict[str, dataclasses.Field[Any]]
        Key name -> field.
    """
    fields = [f for f in dataclasses.fields(schema) if f.init]
    declared = [f for f in fields if key_of(f) is not None]
    return {f.name: f for f in (declared or fields)}


def field_types(schema: type) -> dict[str, Any]:
    """The fields of dataclass ``schema`` with their resolved types.

    Parameters
    ----------
    schema : type
        A dataclass.

    Returns
    -------
    dict[str, Any]
        Field name -> its resolved type.
    """
    hints = typing.get_type_hints(schema)
    return {f.name: hints[f.name] for f in dataclasses.fields(schema)}


def check_given(schema: Any, values: Mapping[str, Any], names: Iterable[str] | None = None) -> None:
    """Each of ``values`` (of ``names``, or all) against its key's rule; ``Refused`` at the first
    that is not allowed. Values are already of the field's type (``rig.params`` parses them).

    Parameters
    ----------
    schema : Any
        The table's dataclass.
    values : Mapping[str, Any]
        Key -> value, already of the field's type.
    names : Iterable[str] | None, optional
        The keys to check (None: all of ``values``).

    Raises
    ------
    Refused
        At the first value not allowed.
    """
    fields = keys(schema)
    for name in values if names is None else names:
        f = fields.get(name)
        spec = key_of(f) if f is not None else None
        if spec is None or f is None:
            continue
        default = f.default if f.default is not dataclasses.MISSING else None
        why = spec.refusal(values[name], default)
        if why is not None:
            raise Refused(name, values[name], why)
