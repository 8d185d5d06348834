"""The ``rig-config`` directive: the configuration reference, generated from the schema.

Every table is a dataclass of the loader (``rig.config.RigConfig``'s fields, walked: a dataclass
field is a table, a tuple of them an array of tables, a dataclass field inside a table its
sub-table); every key is a field: its type, its default, its unit and meaning from the
field's ``#:`` comment (``[s]`` first: the unit). The range is what the loader itself refuses:
each key is given a few values out of the ordinary (negative, zero, huge, infinite, empty, an
unknown name) in an otherwise valid file (``examples/dc_servo_position.toml``), and the rule of
each ``ConfigError`` that names the key is listed. The law's parameters (``[controller]``, per
``kind``) and the presets' (``[emulator.params]``) are read and probed the same way from their
``Params`` dataclasses. Nothing here lists a key by hand.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
import types
import typing
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from docutils import nodes
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.docutils import SphinxDirective

ROOT = Path(__file__).resolve().parents[2]
BASE = ROOT / "examples" / "dc_servo_position.toml"  #: the valid file each probe changes one key of
#: TOML names of RigConfig fields that differ from the field's own name
TOML_NAMES = {"axes": "axis"}
#: values tried for a key of each type (a rule is listed only if the loader refuses one)
PROBES: dict[type, tuple[Any, ...]] = {
    float: (-1e9, -1.0, 0.0, 1e-12, 1e9, math.inf, -math.inf),
    int: (-(2**31) - 1, -1, 0, 128, 256, 70_000, 2**31, 2**32),
    str: ("", "no-such-name", "a/b"),
}


@dataclasses.dataclass
class Key:
    """One key of a table."""

    name: str
    kind: str  #: its type as the file writes it
    default: str
    unit: str
    meaning: str
    rules: list[str]


def _comments(cls: type) -> dict[str, str]:
    """The ``#:`` comment of each field of dataclass ``cls`` (before or beside it)."""
    try:
        docs = ModuleAnalyzer.for_module(cls.__module__).find_attr_docs()
    except Exception:  # no source: no comments
        return {}
    return {
        attr: " ".join(" ".join(lines).split())
        for (owner, attr), lines in docs.items()
        if owner == cls.__qualname__
    }


def _kind(hint: Any) -> str:
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Literal:
        return " | ".join(f'"{a}"' for a in args)
    if origin is tuple:
        return f"list of {_kind(args[0]) if args else 'float'}"
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_kind(a) for a in args if a is not type(None))
    return {float: "float", int: "integer", str: "string", bool: "boolean"}.get(
        hint, getattr(hint, "__name__", str(hint))
    )


def _default(f: dataclasses.Field[Any]) -> str:
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
    else:
        return "required"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if isinstance(value, (dict, tuple)) and not value:
        return "none"
    return repr(value)


def _rule(message: str, key: str, value: Any) -> str | None:
    """The rule a refusal of ``key = value`` states, with the value taken out; None when the
    message is about another key."""
    match = re.search(rf"(?<![\w.]){re.escape(key)}\b", message)
    if match is None:
        return None
    text = message[match.end() :]
    for shown in (repr(value), str(value), repr(float(value)) if isinstance(value, int) else None):
        if shown is not None:
            text = text.replace(f" = {shown}", "", 1).replace(f"={shown}", "", 1)
    text = re.sub(r",? got \S+$", "", text).strip(" :;,")
    return text or None


def _probe(refuse: Callable[[str, Any], str | None], key: str, hint: Any) -> list[str]:
    """The rules the loader states when ``key`` is given each probe value of its type."""
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        values: tuple[Any, ...] = ("no-such-name",)
    elif origin in (typing.Union, types.UnionType):
        inner = [a for a in typing.get_args(hint) if a is not type(None)]
        values = PROBES.get(inner[0], ()) if inner else ()
    else:
        values = PROBES.get(hint, ())
    rules: list[str] = []
    for value in values:
        message = refuse(key, value)
        rule = _rule(message, key, value) if message else None
        if rule and rule not in rules:
            rules.append(rule)
    return rules


def _keys(cls: type, refuse: Callable[[str, Any], str | None] | None, skip: set[str]) -> list[Key]:
    hints = typing.get_type_hints(cls)
    comments = _comments(cls)
    out = []
    for f in dataclasses.fields(cls):
        hint = hints[f.name]
        if f.name in skip or dataclasses.is_dataclass(hint):
            continue
        comment = comments.get(f.name, "")
        unit_match = re.match(r"\[([^\]]+)\]\s*[;:]?\s*", comment)
        unit = unit_match.group(1) if unit_match else ""
        meaning = comment[unit_match.end() :] if unit_match else comment
        rules = _probe(refuse, f.name, hint) if refuse is not None else []
        out.append(Key(f.name, _kind(hint), _default(f), unit, meaning, rules))
    return out


def _loader_refusal(path: tuple[str, ...]) -> Callable[[str, Any], str | None]:
    """``refuse(key, value)``: the loader's ConfigError for the base file with ``key = value`` in
    the table at ``path`` (an array of tables: its first), or None when it loads."""
    from drivers.errors import ConfigError
    from drivers.files import read_toml
    from rig.config import rig_config

    base = read_toml(BASE)

    def refuse(key: str, value: Any) -> str | None:
        doc = copy.deepcopy(base)
        table = doc
        for part in path:
            table = table.setdefault(part, {})
            if isinstance(table, list):
                table = table[0]
        table[key] = value
        try:
            rig_config(doc, "FILE")
        except ConfigError as exc:
            return str(exc)
        return None

    return refuse


def _built_refusal(build: Callable[[dict[str, Any]], Any]) -> Callable[[str, Any], str | None]:
    def refuse(key: str, value: Any) -> str | None:
        try:
            build({key: value})
        except Exception as exc:  # the law's or preset's own check: ConfigError or ValueError
            return str(exc)
        return None

    return refuse


def tables() -> Iterator[tuple[str, type, list[Key]]]:
    """(title, dataclass, keys) of every table of a configuration file, in the file's order."""
    from rig.config import RigConfig

    hints = typing.get_type_hints(RigConfig)
    for f in dataclasses.fields(RigConfig):
        hint = hints[f.name]
        array = typing.get_origin(hint) is tuple
        cls = typing.get_args(hint)[0] if array else hint
        if not dataclasses.is_dataclass(cls):
            continue
        name = TOML_NAMES.get(f.name, f.name)
        yield from _table_and_subtables(name, cls, array, (name,))


def _table_and_subtables(
    name: str, cls: type, array: bool, path: tuple[str, ...]
) -> Iterator[tuple[str, type, list[Key]]]:
    title = f"[[{name}]]" if array else f"[{name}]"
    hints = typing.get_type_hints(cls)
    dict_fields = {f.name for f in dataclasses.fields(cls) if typing.get_origin(hints[f.name]) is dict}
    yield title, cls, _keys(cls, _loader_refusal(path), dict_fields)
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(hints[f.name]):
            sub = f"{name}.{f.name}"
            yield from _table_and_subtables(sub, hints[f.name], False, (*path, f.name))


def laws() -> Iterator[tuple[str, type, list[Key]]]:
    """(kind, Params, keys) of each law ``[controller] kind`` names (the period fills dt, ts)."""
    from rig.laws import LAWS, law_class
    from rig.params import build

    for kind in LAWS:
        params = law_class(kind).Params
        names = {f.name for f in dataclasses.fields(params)}
        fixed = {k: 4e-4 for k in ("dt", "ts") if k in names}
        refuse = _built_refusal(lambda items, p=params, x=fixed: build(p, items, "[controller]", **x))
        yield kind, params, _keys(params, refuse, set(fixed))


def presets() -> Iterator[tuple[str, type, list[Key]]]:
    """(preset, its parameters' dataclass, keys) for ``[emulator.params]``."""
    from plant_emulator.parameters import with_params
    from plant_emulator.presets import PRESETS

    for name, cls in PRESETS.items():
        yield name, cls, _keys(cls, _built_refusal(lambda items, c=cls: with_params(c, items)), set())


def _key_table(keys: list[Key]) -> nodes.table:
    headers = ("key", "type", "default", "unit", "meaning", "refused unless")
    table = nodes.table()
    group = nodes.tgroup(cols=len(headers))
    table += group
    for width in (14, 12, 10, 6, 30, 28):
        group += nodes.colspec(colwidth=width)
    head = nodes.thead()
    body = nodes.tbody()
    group += head
    group += body
    head += _row(headers, literal_first=False)
    for k in keys:
        body += _row((k.name, k.kind, k.default, k.unit, k.meaning, "; ".join(k.rules)), literal_first=True)
    return table


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
    """``rig-config``: a section per table of the configuration file, then the laws' and presets'."""

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
        return out

    def _section(self, title: str, cls: type | None, keys: list[Key]) -> nodes.section:
        section = nodes.section(
            ids=[nodes.make_id("config " + title)], names=[nodes.fully_normalize_name(title)]
        )
        self.state.document.note_implicit_target(section)
        section += nodes.title(text=title)
        doc = (cls.__doc__ or "") if cls is not None else ""
        if doc and not doc.startswith(f"{cls.__name__}("):  # not the dataclass's own signature
            section += nodes.paragraph(text=" ".join(doc.split()))
        if keys:
            section += _key_table(keys)
        return section


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("rig-config", RigConfigDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
