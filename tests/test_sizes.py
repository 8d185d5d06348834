"""Sizes kept (issue 37 item 4): no module of the four packages over ``MODULE`` lines, no function
or method over ``FUNCTION`` (its ``def`` line to its last, decorators aside), no class over
``CLASS``, measured from the source with ``ast``. ``DEBTS`` lists today's exceptions with their
sizes: one may shrink (write its new size, or take it out once under the limit), none may grow,
and nothing new may join it.

The numpydoc sections a docstring must have (``Parameters``, ``Returns``, ``Raises`` ...: item 5,
tests/test_docstrings.py) are not counted, from the blank line before the first to the docstring's
end: the summary and prose above them count as code does, so a docstring made numpydoc measures
as it did before.
"""

from __future__ import annotations

import ast
import functools
import pathlib
from collections.abc import Iterator

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = ("rig", "drivers", "controllers", "plant_emulator")
MODULE, FUNCTION, CLASS = 400, 60, 300  #: [lines]

#: what is over its limit today -> its size [lines]; "path" a module, "path::Class.method" the rest
DEBTS: dict[str, int] = {
    "plant_emulator/canopen_node.py::EmulatedNode": 317,
    "plant_emulator/im_kernel.py::_foc_periods": 68,
    "plant_emulator/socketcand_server.py": 403,
    "plant_emulator/socketcand_server.py::SocketcandServer": 320,
}


#: the numpydoc section titles whose lines are not counted
SECTIONS = ("Parameters", "Attributes", "Returns", "Yields", "Raises", "Warns", "See Also")


def section_lines(tree: ast.AST, lines: list[str]) -> set[int]:
    """The line numbers (1-based) of the docstrings' numpydoc sections: from the blank line before
    the first section's title to the docstring's last line."""
    found: set[int] = set()
    for node in ast.walk(tree):
        if not isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        first = node.body[0] if node.body else None
        if not (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)):
            continue
        if not isinstance(first.value.value, str) or first.end_lineno is None:
            continue
        for number in range(first.lineno, first.end_lineno):
            title, rule = lines[number - 1].strip(), lines[number].strip()
            if title in SECTIONS and rule == "-" * len(title):
                start = number - 1 if not lines[number - 2].strip() else number
                found.update(range(start, first.end_lineno + 1))
                break
    return found


def sizes(path: pathlib.Path, name: str) -> Iterator[tuple[str, int, int]]:
    """(name, lines, limit) of the module at ``path`` (called ``name``), then of each function and
    class in it, nested ones by their dotted names; docstrings' numpydoc sections not counted."""
    text = path.read_text()
    tree = ast.parse(text)
    lines = text.splitlines()
    skipped = section_lines(tree, lines)
    yield name, len(lines) - len(skipped), MODULE

    def inside(node: ast.AST, prefix: str) -> Iterator[tuple[str, int, int]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                limit = CLASS if isinstance(child, ast.ClassDef) else FUNCTION
                assert child.end_lineno is not None
                span = range(child.lineno, child.end_lineno + 1)
                yield f"{prefix}{child.name}", len(span) - len(skipped.intersection(span)), limit
                yield from inside(child, f"{prefix}{child.name}.")
            else:
                yield from inside(child, prefix)

    yield from ((f"{name}::{n}", size, limit) for n, size, limit in inside(tree, ""))


@functools.cache
def measured() -> dict[str, tuple[int, int]]:
    """Everything of the four packages -> (its lines, its limit)."""
    return {
        name: (size, limit)
        for package in PACKAGES
        for path in sorted((ROOT / package).rglob("*.py"))
        for name, size, limit in sizes(path, str(path.relative_to(ROOT)))
    }


def test_no_module_function_or_class_over_its_limit() -> None:
    found = measured()
    over = {name: size for name, (size, limit) in found.items() if size > limit}
    new = [
        f"{name}: {over[name]} lines, over {found[name][1]}" for name in sorted(over.keys() - DEBTS.keys())
    ]
    owed = sorted(over.keys() & DEBTS.keys())
    grown = [f"{name}: {over[name]} lines, was {DEBTS[name]}" for name in owed if over[name] > DEBTS[name]]
    assert not new and not grown, (
        "over the size limits (split it: small modules named for what they hold):\n" + "\n".join(new + grown)
    )


def test_the_debts_are_still_owed() -> None:
    """A debt paid is taken out of ``DEBTS``, a smaller one written with its new size: the list
    only shrinks."""
    found = measured()
    stale = [
        f"{name}: {found[name][0]} lines now (DEBTS says {size})" if name in found else f"{name}: gone"
        for name, size in sorted(DEBTS.items())
        if found.get(name, (0, 0))[0] != size
    ]
    assert not stale, "update tests/test_sizes.py DEBTS:\n" + "\n".join(stale)


def test_sizes_are_measured_from_def_to_last_line(tmp_path: pathlib.Path) -> None:
    source = tmp_path / "m.py"
    source.write_text(
        "@deco\nclass A:\n    def f(self):\n        def g():\n            pass\n        return 1\n"
    )
    assert list(sizes(source, "m.py")) == [
        ("m.py", 6, MODULE),
        ("m.py::A", 5, CLASS),
        ("m.py::A.f", 4, FUNCTION),
        ("m.py::A.f.g", 2, FUNCTION),
    ]


def test_numpydoc_sections_are_not_counted(tmp_path: pathlib.Path) -> None:
    """A one-line docstring made numpydoc measures as before: its summary counts, its sections not."""
    plain = tmp_path / "plain.py"
    plain.write_text('def f(x):\n    """Double x."""\n    return 2 * x\n')
    sectioned = tmp_path / "sectioned.py"
    sectioned.write_text(
        'def f(x):\n    """Double x.\n\n    Parameters\n    ----------\n    x : float\n        The value.\n'
        '\n    Returns\n    -------\n    float\n        2 x.\n    """\n    return 2 * x\n'
    )
    assert [size for _, size, _ in sizes(plain, "m")] == [3, 3]
    assert [size for _, size, _ in sizes(sectioned, "m")] == [3, 3]
