"""Public functions and classes have numpydoc docstrings (issue 37 item 5), checked as python-control
checks its own: from the code, so a parameter added without its entry fails.

For each public function, method and class of a module in COVERED: a docstring; a ``Parameters``
section naming every parameter of the signature (a class's: its constructor's, where a dataclass
field's ``#:`` comment, or the ``doc`` of its ``drivers.schema.key``, counts as its entry); a
``Returns`` (or ``Yields``) section where the return annotation is not None; a ``Raises`` section
naming every exception the body raises by name (a class's: its ``__init__``'s and
``__post_init__``'s; ``raise self._make(...)``: the exception ``_make`` is annotated to return;
not those its own ``except`` catches). A method overriding one without a docstring of its own is
held to the docstring it inherits, as autodoc shows it. COVERED only grows and NOT_YET only
shrinks: a module covered stays covered; docs/api.md says how far it reaches.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import re
import textwrap
from collections.abc import Callable, Iterator
from typing import Any

import pytest

#: the modules held to it (``package.*``: the package and every module below it, but NOT_YET)
COVERED = [
    "controllers.*",
    "drivers.*",
    "plant_emulator.*",
    "rig",
    "rig.bench.*",
    "rig.cli.*",
    "rig.commission.*",
    "rig.config.*",
    "rig.doctor.*",
    "rig.emulator.*",
    "rig.faults.*",
    "rig.host.*",
    "rig.identify.*",
    "rig.laws.*",
    "rig.live.*",
    "rig.papers.*",
    "rig.report.*",
    "rig.sweep.*",
    "rig.view.*",
]

#: modules below COVERED's packages still to document (this list only shrinks): none left
NOT_YET: list[str] = []


SECTION = re.compile(r"^(\w[\w ]*)\n-+\n", re.MULTILINE)


def sections(doc: str) -> dict[str, str]:
    """A numpydoc docstring's sections: title -> body (the summary under "")."""
    doc = inspect.cleandoc(doc) + "\n"
    found: dict[str, str] = {}
    marks = list(SECTION.finditer(doc))
    found[""] = doc[: marks[0].start()] if marks else doc
    for mark, after in zip(marks, [*marks[1:], None][: len(marks)], strict=True):
        found[mark.group(1)] = doc[mark.end() : after.start() if after else len(doc)]
    return found


def entries(body: str) -> set[str]:
    """The names a Parameters or Raises section lists (its unindented lines, before any " : ")."""
    names = set()
    for line in body.splitlines():
        if line and not line[0].isspace():
            for name in line.split(" : ")[0].split(","):
                names.add(name.strip().lstrip("*"))
    return names


def made_by(func: Callable[..., Any], method: str) -> str:
    """The exception a factory method of ``func``'s class returns (``raise self._fault()``): the
    name its return annotation gives, else ``method``'s own."""
    owner = func.__globals__.get(func.__qualname__.split(".")[0])
    factory = getattr(owner, method, None)
    made = getattr(factory, "__annotations__", {}).get("return")
    return str(made).split(".")[-1] if made else method


def raised(func: Callable[..., Any]) -> set[str]:
    """The exception names ``func``'s own body raises (``raise Name(...)``, not nested functions';
    ``raise self.make(...)``: the exception ``make`` is annotated to return)."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    except (OSError, TypeError):
        return set()
    names = set()

    def caught(handler: ast.ExceptHandler) -> set[str]:
        kinds = handler.type.elts if isinstance(handler.type, ast.Tuple) else [handler.type]
        return {
            k.id if isinstance(k, ast.Name) else k.attr
            for k in kinds
            if isinstance(k, ast.Name | ast.Attribute)
        }

    def walk(node: ast.AST, top: bool, kept: frozenset[str] = frozenset()) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda) and not top:
            return
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id[:1].isupper():
                name = exc.id
            elif isinstance(exc, ast.Attribute) and isinstance(node.exc, ast.Call) and exc.attr[:1] == "_":
                name = made_by(func, exc.attr)
            else:
                name = exc.attr if isinstance(exc, ast.Attribute) and exc.attr[:1].isupper() else ""
            if name and name not in kept:
                names.add(name)
        if isinstance(node, ast.Try):  # what its handlers catch, raised in its body, stays inside
            inner = kept.union(*(caught(h) for h in node.handlers))
            for child in node.body:
                walk(child, False, inner)
            for child in [*node.handlers, *node.orelse, *node.finalbody]:
                walk(child, False, kept)
            return
        for child in ast.iter_child_nodes(node):
            walk(child, False, kept)

    walk(tree.body[0], True)
    return names


def commented_fields(cls: type) -> set[str]:
    """The class's fields documented by a ``#:`` comment (on their line or the line above)."""
    try:
        lines = inspect.getsource(cls).splitlines()
    except (OSError, TypeError):
        return set()
    names = set()
    for i, line in enumerate(lines):
        field = re.match(r"\s+(\w+)\s*:", line)
        if field and ("#:" in line or (i and lines[i - 1].strip().startswith("#:"))):
            names.add(field.group(1))
    return names


def keyed_fields(cls: type) -> set[str]:
    """The class's fields declared with ``drivers.schema.key`` and a ``doc`` (what the key means,
    which the configuration reference prints)."""
    fields = dataclasses.fields(cls)  # type: ignore[arg-type]
    return {f.name for f in fields if getattr(f.metadata.get("key"), "doc", "")}


def problems_of(
    name: str, func: Callable[..., Any], doc: str | None, owner: type | None = None
) -> Iterator[str]:
    """What ``func``'s docstring ``doc`` lacks (``owner``: the class whose constructor it is)."""
    if not doc:
        yield f"{name}: no docstring"
        return
    parts = sections(doc)
    try:
        signature = inspect.signature(func)
    except (TypeError, ValueError):
        return
    params = [p for p in signature.parameters if p not in ("self", "cls")]
    documented = entries(parts.get("Parameters", "")) | entries(parts.get("Attributes", ""))
    if owner is not None and dataclasses.is_dataclass(owner):
        documented |= commented_fields(owner) | keyed_fields(owner)
    missing = [p for p in params if p not in documented]
    if missing:
        yield f"{name}: Parameters lacks {missing}"
    returns = signature.return_annotation
    if owner is None and returns not in (None, "None", inspect.Signature.empty, "NoReturn"):
        if "Returns" not in parts and "Yields" not in parts:
            yield f"{name}: no Returns section (returns {returns})"
    if owner is not None:
        exceptions = raised(getattr(owner, "__post_init__", lambda: None)) | raised(func)
    else:
        exceptions = raised(func)
    unlisted = exceptions - entries(parts.get("Raises", ""))
    if unlisted:
        yield f"{name}: Raises lacks {sorted(unlisted)}"


def method_doc(cls: type, member: str) -> str | None:
    """The docstring of ``cls``'s method ``member``: its own, else (an override without one) that of
    the nearest class of its MRO that has one, as autodoc shows it."""
    for klass in cls.__mro__:
        value = klass.__dict__.get(member)
        func = value.__func__ if isinstance(value, staticmethod | classmethod) else value
        if inspect.isfunction(func) and func.__doc__:
            return str(func.__doc__)
    return None


def public(module: Any) -> Iterator[tuple[str, Any]]:
    """The module's own public classes and functions."""
    exported = getattr(module, "__all__", None)
    for attr, obj in vars(module).items():
        if not (inspect.isclass(obj) or inspect.isfunction(obj)) or obj.__module__ != module.__name__:
            continue
        if (attr in exported) if exported is not None else not attr.startswith("_"):
            yield attr, obj


def problems(module_name: str) -> list[str]:
    module = importlib.import_module(module_name)
    found: list[str] = []
    for attr, obj in public(module):
        name = f"{module_name}.{attr}"
        if inspect.isfunction(obj):
            found += problems_of(name, obj, obj.__doc__)
            continue
        init = obj.__dict__.get("__init__")
        if init is None or not init.__qualname__.startswith(f"{obj.__qualname__}."):
            init = lambda: None  # noqa: E731 (a Protocol's, which takes nothing)
        found += problems_of(name, init, obj.__doc__, owner=obj)
        for member, value in obj.__dict__.items():
            if member.startswith("_"):
                continue
            func = value.__func__ if isinstance(value, staticmethod | classmethod) else value
            if inspect.isfunction(func):
                found += problems_of(f"{name}.{member}", func, method_doc(obj, member))
    return found


def covered() -> list[str]:
    """The modules of COVERED, ``package.*`` standing for the package and every module below it
    (a ``__main__`` module aside: importing it runs it), but NOT_YET's."""
    import pkgutil

    names = []
    for entry in COVERED:
        name = entry.removesuffix(".*")
        names.append(name)
        if entry.endswith(".*"):
            module = importlib.import_module(name)
            names += [m.name for m in pkgutil.walk_packages(module.__path__, prefix=f"{name}.")]
    return sorted(set(names) - set(NOT_YET) - {n for n in names if n.endswith(".__main__")})


@pytest.mark.parametrize("module_name", covered())
def test_numpydoc(module_name: str) -> None:
    """Every public function, method and class of the module has its numpydoc sections."""
    found = problems(module_name)
    assert not found, "\n".join(found)


def test_checker_sees_what_is_missing() -> None:
    """The check fails a function without Parameters, Returns or Raises, and passes a full one."""

    def bare(x: float) -> float:
        """Double x."""
        if x < 0:
            raise ValueError(x)
        return 2 * x

    def full(x: float) -> float:
        """Double x.

        Parameters
        ----------
        x : float
            The value.

        Returns
        -------
        float
            2 x.

        Raises
        ------
        ValueError
            If x < 0.
        """
        if x < 0:
            raise ValueError(x)
        return 2 * x

    assert len(list(problems_of("bare", bare, bare.__doc__))) == 3
    assert not list(problems_of("full", full, full.__doc__))


class _Device:
    """A class whose method raises what a factory method makes."""

    def _fault(self) -> KeyError:
        return KeyError("fault")

    def check(self, x: float) -> None:
        """Raise the device's fault where x < 0, and a ValueError caught inside.

        Parameters
        ----------
        x : float
            The value.
        """
        try:
            raise ValueError(x)
        except ValueError:
            pass
        if x < 0:
            raise self._fault()


def test_checker_names_what_a_factory_makes() -> None:
    """``raise self._fault()`` asks for the exception ``_fault`` returns (KeyError) in Raises; a
    ValueError its own handler catches is not asked for."""
    found = list(problems_of("check", _Device.check, _Device.check.__doc__))
    assert found == ["check: Raises lacks ['KeyError']"]


def test_checker_takes_inherited_docstrings_and_key_docs() -> None:
    """An override without a docstring is held to the one it inherits; a dataclass field declared
    with ``key(..., doc=...)`` needs no other entry."""
    from drivers.schema import key

    class Base:
        def f(self, x: float) -> None:
            """Take x.

            Parameters
            ----------
            x : float
                The value.
            """

    class Child(Base):
        def f(self, x: float) -> None:
            pass

    @dataclasses.dataclass
    class Table:
        """A table."""

        gain: float = key(1.0, "1", "the gain")

    assert not list(problems_of("f", Child.f, method_doc(Child, "f")))
    assert list(problems_of("f", Child.f, Child.f.__doc__)) == ["f: no docstring"]
    assert not list(problems_of("Table", Table.__init__, Table.__doc__, owner=Table))
