"""The ``rig-config`` directive: the configuration reference, generated from the schema.

The schema is the one the loader checks (``rig.config``): every table is a dataclass
(``rig.config.RigConfig``'s fields, walked: a dataclass field is a table, a tuple of them an
array of tables, a dataclass field inside a table its sub-table); every key is a field declared
with ``drivers.schema.key``, whose metadata (``drivers.schema.Key``) holds its unit, its meaning
and the values it allows (``Key.text()``: what the loader's "must be" says). The type and the
default are the field's own. The laws' parameters (``[controller]``, per ``kind``:
``rig.laws.LAWS``' ``Params``), the presets' (``[emulator.params]``: ``PRESETS``) and the
emulated inverters' (``[emulator.inverter]``: ``InverterModel``) are read the same way. Nothing
here lists a key by hand or asks the loader.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Iterator
from typing import Any

from docutils import nodes
from sphinx.util.docutils import SphinxDirective

#: TOML names of RigConfig fields that differ from the field's own name
TOML_NAMES = {"axes": "axis"}
#: how the file writes a value of a field whose type is what the loader makes of it
FILE_TYPES = {"Model": "string (a file's path)"}


@dataclasses.dataclass
class Row:
    """One key of a table, as printed."""

    name: str
    kind: str  #: its type as the file writes it
    default: str
    unit: str
    meaning: str
    allowed: str


def _kind(hint: Any) -> str:
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Literal:
        return " | ".join(f'"{a}"' for a in args)
    if origin is tuple:
        return f"list of {_kind(args[0]) if args else 'float'}"
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_kind(a) for a in args if a is not type(None))
    name = getattr(hint, "__name__", str(hint))
    return {"float": "float", "int": "integer", "str": "string", "bool": "boolean"}.get(
        name, FILE_TYPES.get(name, name)
    )


def _default(f: dataclasses.Field[Any]) -> str:
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
    else:
        return "required"
    if value is None:
        return "none"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if isinstance(value, (dict, tuple)) and not value:
        return "none"
    return repr(value)


def rows(cls: type) -> list[Row]:
    """The keys of schema dataclass ``cls`` (``drivers.schema.keys``), as printed."""
    from drivers.schema import key_of, keys

    hints = typing.get_type_hints(cls)
    out = []
    for name, f in keys(cls).items():
        hint = hints[name]
        if dataclasses.is_dataclass(hint) or typing.get_origin(hint) is dict:
            continue  # a sub-table, printed as its own section
        spec = key_of(f)
        if spec is None:  # pragma: no cover - a schema field declared without key()
            raise TypeError(f"{cls.__qualname__}.{name} is not declared with drivers.schema.key")
        meaning = spec.doc + (f" ({' and '.join(spec.kinds)} axes)" if spec.kinds else "")
        out.append(Row(name, _kind(hint), _default(f), spec.unit, meaning, _allowed(spec, hint)))
    return out


def _allowed(spec: Any, hint: Any) -> str:
    """The values a key allows beyond its type: a number's range (``Key.text()``), else its rule
    in words, or the first sentence of its ``check`` function's docstring."""
    inner = [a for a in typing.get_args(hint) if a is not type(None)] or [hint]
    if typing.get_origin(inner[0]) is tuple:  # a list: what each of its items allows
        inner = list(typing.get_args(inner[0])[:1]) or [float]
    if typing.get_origin(inner[0]) is tuple:  # a list of lists (rows) of numbers
        inner = [float]
    if any(a in (float, int) for a in inner):
        text: str = spec.text()
        return text
    if spec.rule:
        return str(spec.rule)
    doc = (getattr(spec.check, "__doc__", None) or "").strip().replace("``", "")
    return " ".join(doc.split(". ")[0].split()).rstrip(".")


def tables() -> Iterator[tuple[str, type, list[Row]]]:
    """(title, dataclass, rows) of every table of a configuration file, in the file's order."""
    from rig.config import RigConfig

    hints = typing.get_type_hints(RigConfig)
    for f in dataclasses.fields(RigConfig):
        hint = hints[f.name]
        array = typing.get_origin(hint) is tuple
        cls = typing.get_args(hint)[0] if array else hint
        if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
            continue
        name = TOML_NAMES.get(f.name, f.name)
        yield from _table_and_subtables(name, cls, array)


def _table_and_subtables(name: str, cls: type, array: bool) -> Iterator[tuple[str, type, list[Row]]]:
    yield (f"[[{name}]]" if array else f"[{name}]"), cls, rows(cls)
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(hints[f.name]):
            yield from _table_and_subtables(f"{name}.{f.name}", hints[f.name], False)


def laws() -> Iterator[tuple[str, type, list[Row]]]:
    """(kind, Params, rows) of each law ``[controller] kind`` names."""
    from rig.laws import LAWS, law_class

    for kind in LAWS:
        params = law_class(kind).Params
        yield kind, params, rows(params)


def presets() -> Iterator[tuple[str, type, list[Row]]]:
    """(preset, its parameters' dataclass, rows) for ``[emulator.params]``."""
    from plant_emulator.presets import PRESETS

    for name, cls in PRESETS.items():
        yield name, cls, rows(cls)


def inverter() -> tuple[type, list[Row]]:
    """The emulated Modbus inverters' parameters, ``[emulator.inverter]``."""
    from plant_emulator.inverter_model import InverterModel

    return InverterModel, rows(InverterModel)


def _key_table(keys: list[Row]) -> nodes.table:
    headers = ("key", "type", "default", "unit", "meaning", "allowed")
    table = nodes.table()
    group = nodes.tgroup(cols=len(headers))
    table += group
    for width in (14, 12, 10, 8, 32, 24):
        group += nodes.colspec(colwidth=width)
    head = nodes.thead()
    body = nodes.tbody()
    group += head
    group += body
    head += _row(headers, literal_first=False)
    for k in keys:
        body += _row((k.name, k.kind, k.default, k.unit, k.meaning, k.allowed), literal_first=True)
    return table


def _paragraph(text: str) -> nodes.paragraph:
    """``text`` with its ````code```` spans as literals."""
    paragraph = nodes.paragraph()
    for i, part in enumerate(text.split("``")):
        if part:
            paragraph += nodes.literal(text=part) if i % 2 else nodes.Text(part)
    return paragraph


def _row(cells: tuple[str, ...], literal_first: bool) -> nodes.row:
    row = nodes.row()
    for i, text in enumerate(cells):
        entry = nodes.entry()
        paragraph = nodes.paragraph()
        paragraph += nodes.literal(text=text) if literal_first and i == 0 else nodes.Text(text)
        entry += paragraph
        row += entry
    return row


class RigConfigDirective(SphinxDirective):
    """``rig-config``: a section per table of the configuration file, then the laws', the presets'
    and the emulated inverters' parameters."""

    def run(self) -> list[nodes.Node]:
        out: list[nodes.Node] = []
        for title, cls, keys in tables():
            out.append(self._section(title, cls, keys))
        laws_section = self._section("[controller] parameters of each law", None, [])
        for kind, cls, keys in laws():
            laws_section += self._section(f'kind = "{kind}"', cls, keys)
        out.append(laws_section)
        presets_section = self._section("[emulator.params] of each preset", None, [])
        for name, cls, keys in presets():
            presets_section += self._section(f'preset = "{name}"', cls, keys)
        out.append(presets_section)
        out.append(self._section("[emulator.inverter]", *inverter()))
        return out

    def _section(self, title: str, cls: type | None, keys: list[Row]) -> nodes.section:
        section = nodes.section(
            ids=[nodes.make_id("config " + title)], names=[nodes.fully_normalize_name(title)]
        )
        self.state.document.note_implicit_target(section)
        section += nodes.title(text=title)
        doc = (cls.__doc__ or "") if cls is not None else ""
        if cls is not None and doc and not doc.startswith(f"{cls.__name__}("):  # not its signature
            section += _paragraph(" ".join(doc.split()))
        if keys:
            section += _key_table(keys)
        return section


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("rig-config", RigConfigDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
