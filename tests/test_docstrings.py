"""Public functions and classes have numpydoc docstrings (issue 37 item 5), checked as python-control
checks its own: from the code, so a parameter added without its entry fails.

For each public function, method and class of a module in COVERED: a docstring; a ``Parameters``
section naming every parameter of the signature (a class's: its constructor's, where a dataclass
field's ``#:`` comment counts as its entry); a ``Returns`` (or ``Yields``) section where the return
annotation is not None; a ``Raises`` section naming every exception the body raises by name (a
class's: its ``__init__``'s and ``__post_init__``'s). COVERED only grows: a module in it stays
covered; docs/api.md says how far it reaches.
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

#: the modules held to it (``package.*``: the package and every module below it)
COVERED = [
    "controllers.*",
    "drivers",
    "drivers.maps",
    "drivers.cia402_feedback",
    "drivers.errors",
    "drivers.maps.build_eds",
    "drivers.maps.cia406",
    "drivers.maps.emcy",
    "drivers.maps.mode_names",
    "drivers.maps.sdo_aborts",
    "drivers.maps.vendors",
    "plant_emulator",
    "plant_emulator.devices",
    "plant_emulator.devices.catalog",
    "plant_emulator.drive_safety",
    "plant_emulator.encoder",
    "plant_emulator.frame",
    "plant_emulator.friction",
    "plant_emulator.im_kernel",
    "plant_emulator.pty_link",
    "plant_emulator.zoh",
]

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


def raised(func: Callable[..., Any]) -> set[str]:
    """The exception names ``func``'s own body raises (``raise Name(...)``, not nested functions')."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    except (OSError, TypeError):
        return set()
    names = set()

    def walk(node: ast.AST, top: bool) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda) and not top:
            return
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id[:1].isupper():
                names.add(exc.id)
            elif isinstance(exc, ast.Attribute):
                names.add(exc.attr)
        for child in ast.iter_child_nodes(node):
            walk(child, False)

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
        documented |= commented_fields(owner)
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
                found += problems_of(f"{name}.{member}", func, func.__doc__)
    return found


def covered() -> list[str]:
    """The modules of COVERED, ``package.*`` standing for the package and every module below it."""
    import pkgutil

    names = []
    for entry in COVERED:
        name = entry.removesuffix(".*")
        names.append(name)
        if entry.endswith(".*"):
            module = importlib.import_module(name)
            names += [m.name for m in pkgutil.walk_packages(module.__path__, prefix=f"{name}.")]
    return sorted(set(names))


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
