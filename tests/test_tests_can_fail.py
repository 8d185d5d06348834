"""Tests that can fail (issue 37 item 6), read from the tests' source with ``ast``:

- every test reaches a check: an ``assert``, a ``raise``, ``pytest.raises``/``warns``/``fail``, or
  a call of a function of tests/ that does (a test that only calls the code passes whatever the
  code returns);
- a patch of a module's name is seen by the code under test: ``monkeypatch.setattr`` of a name a
  module defines, which another module of ours bound at import (``from module import name``),
  leaves that module calling the original (tests/rig/test_cli.py's ``nothing_opens`` patched
  ``drivers.bus.open_bus`` while ``rig.host.session`` called its own binding): patch it where it
  is bound (``tests.patching.stand_in``);
- ``pytest.raises`` of a wide type (``Exception``, ``OSError``, ``SystemExit``, ...) says which
  one it expects, by ``match=`` or by checking the caught exception (``as exc``, then ``exc``
  read): a usage error's SystemExit(2) or another OSError than the one meant passes otherwise.
"""

from __future__ import annotations

import ast
import functools
import pathlib
from collections.abc import Iterator

from tests.test_layers import modules

ROOT = pathlib.Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"

#: calls that are checks themselves
CHECKS = {"raises", "warns", "fail", "check_output", "check_call", "assert_allclose", "assert_array_equal"}
#: exception types too wide to be caught without saying which one is meant
WIDE = {"Exception", "BaseException", "OSError", "SystemExit", "ValueError", "RuntimeError", "TypeError"}


@functools.cache
def _sources() -> dict[pathlib.Path, ast.Module]:
    return {p: ast.parse(p.read_text(), str(p)) for p in sorted(TESTS.rglob("*.py"))}


def _functions(tree: ast.AST) -> Iterator[ast.FunctionDef | ast.AsyncFunctionDef]:
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


def _called(node: ast.AST) -> set[str]:
    """The names ``node`` calls or refers to (a helper handed to another call counts)."""
    names = set()
    for sub in ast.walk(node):
        if isinstance(sub, ast.Call) and isinstance(sub.func, ast.Attribute):
            names.add(sub.func.attr)
        elif isinstance(sub, ast.Name):
            names.add(sub.id)
    return names


def _checks_itself(node: ast.AST) -> bool:
    for sub in ast.walk(node):
        if isinstance(sub, (ast.Assert, ast.Raise)):
            return True
        if isinstance(sub, ast.Call) and isinstance(sub.func, ast.Attribute) and sub.func.attr in CHECKS:
            return True
    return False


def checking_helpers(trees: dict[pathlib.Path, ast.Module]) -> set[str]:
    """Names of the functions of tests/ that check something, themselves or through another."""
    defined: dict[str, list[ast.AST]] = {}
    for tree in trees.values():
        for f in _functions(tree):
            defined.setdefault(f.name, []).append(f)
    checking = {name for name, fs in defined.items() if any(_checks_itself(f) for f in fs)}
    calls = {name: set().union(*(_called(f) for f in fs)) for name, fs in defined.items()}
    grown = True
    while grown:
        grown = False
        for name in calls.keys() - checking:
            if calls[name] & checking:
                checking.add(name)
                grown = True
    return checking


def test_every_test_reaches_a_check() -> None:
    trees = _sources()
    checking = checking_helpers(trees)
    unchecked = [
        f"{path.relative_to(ROOT)}:{f.lineno} {f.name}"
        for path, tree in trees.items()
        if path.name.startswith("test_")
        for f in _functions(tree)
        if f.name.startswith("test_") and not _checks_itself(f) and not _called(f) & checking
    ]
    assert len(checking) > 100 and not unchecked, f"tests that check nothing: {unchecked}"


@functools.cache
def _project_modules() -> dict[str, ast.Module]:
    """Every module of the four packages by dotted name (``tests.test_layers.modules``), parsed."""
    return {name: ast.parse(path.read_text(), str(path)) for name, path in modules().items()}


def bound_elsewhere(modules: dict[str, ast.Module]) -> dict[tuple[str, str], list[str]]:
    """(module, name) -> the other modules of ours that bind it with ``from module import name``."""
    found: dict[tuple[str, str], list[str]] = {}
    for importer, tree in modules.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for alias in node.names:
                    found.setdefault((node.module, alias.name), []).append(importer)
    return found


def _aliases(tree: ast.Module) -> dict[str, str]:
    """A test file's names of modules (anywhere in it) -> the module's dotted name."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                names[alias.asname or alias.name] = alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            for alias in node.names:
                names[alias.asname or alias.name] = f"{node.module}.{alias.name}"
    return names


def _dotted(node: ast.expr) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        base = _dotted(node.value)
        return f"{base}.{node.attr}" if base else None
    return None


def _texts(node: ast.expr) -> list[str]:
    """The strings of a tuple or list of string constants, else none."""
    if isinstance(node, (ast.Tuple, ast.List)):
        return [e.value for e in node.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)]
    return []


def _targets(tree: ast.Module) -> dict[ast.Call, list[str]]:
    """Each ``monkeypatch.setattr(target, ...)`` call -> the dotted targets it patches: a string
    constant, or each string of what a ``for`` over a tuple of strings (written there or a
    module-level name of one) gives its variable."""
    named = {
        t.id: _texts(node.value)
        for node in tree.body
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None
        for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
        if isinstance(t, ast.Name)
    }
    looped: dict[str, list[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.For, ast.comprehension)) and isinstance(node.target, ast.Name):
            it = node.iter
            looped[node.target.id] = _texts(it) or (named.get(it.id, []) if isinstance(it, ast.Name) else [])
    found: dict[ast.Call, list[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.args:
            if node.func.attr == "setattr" and _dotted(node.func.value) == "monkeypatch":
                first = node.args[0]
                if isinstance(first, ast.Constant) and isinstance(first.value, str):
                    found[node] = [first.value]
                elif isinstance(first, ast.Name) and len(node.args) == 2:
                    found[node] = looped.get(first.id, [])
    return found


def patches(tree: ast.Module, known: set[str]) -> Iterator[tuple[int, str, str]]:
    """(line, module, name) of each ``monkeypatch.setattr`` of a module's name in ``tree``."""
    aliases = _aliases(tree)
    targets = _targets(tree)
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        named = [tuple(target.rpartition(".")[::2]) for target in targets.get(node, [])]
        if not named and node in targets:
            continue
        if not named and isinstance(node.func, ast.Attribute) and node.func.attr == "setattr":
            if _dotted(node.func.value) != "monkeypatch" or len(node.args) < 2:
                continue
            if not isinstance(node.args[1], ast.Constant):
                continue
            dotted = _dotted(node.args[0]) or ""
            head, _, rest = dotted.partition(".")
            named = [(".".join(filter(None, (aliases.get(head, head), rest))), str(node.args[1].value))]
        for module, name in named:
            if module in known:
                yield node.lineno, module, name


def test_a_patched_name_is_not_bound_elsewhere() -> None:
    modules = _project_modules()
    elsewhere = bound_elsewhere(modules)
    unseen = [
        f"{path.relative_to(ROOT)}:{line} patches {module}.{name}, which "
        f"{', '.join(elsewhere[module, name])} bound at import: patch it there too (tests.patching.stand_in)"
        for path, tree in _sources().items()
        for line, module, name in patches(tree, set(modules))
        if (module, name) in elsewhere
    ]
    assert not unseen, "\n".join(unseen)


def wide_catches(tree: ast.Module) -> Iterator[tuple[int, str]]:
    """(line, type) of each ``with pytest.raises(T)`` of a wide type that neither matches the
    message nor reads the exception caught."""
    for f in _functions(tree):
        for node in ast.walk(f):
            if not isinstance(node, (ast.With, ast.AsyncWith)):
                continue
            for item in node.items:
                call = item.context_expr
                if not (isinstance(call, ast.Call) and _dotted(call.func) == "pytest.raises" and call.args):
                    continue
                kinds = call.args[0].elts if isinstance(call.args[0], ast.Tuple) else [call.args[0]]
                wide = [k for k in (_dotted(k) for k in kinds) if k in WIDE]
                if not wide or any(k.arg == "match" for k in call.keywords):
                    continue
                var = item.optional_vars
                read = isinstance(var, ast.Name) and any(
                    isinstance(n, ast.Name) and n.id == var.id and isinstance(n.ctx, ast.Load)
                    for n in ast.walk(f)
                )
                if not read:
                    yield call.lineno, ", ".join(wide)


def test_a_wide_exception_is_caught_only_as_the_one_meant() -> None:
    found = [
        f"{path.relative_to(ROOT)}:{line} pytest.raises({kind}) without match= or a check of what it caught"
        for path, tree in _sources().items()
        for line, kind in wide_catches(tree)
    ]
    assert not found, "\n".join(found)


def test_the_checks_find_what_they_name() -> None:
    """Each check above finds its fault in a test written with it."""
    written = ast.parse(
        "import drivers.bus\n"
        "def test_a(monkeypatch):\n"
        "    monkeypatch.setattr(drivers.bus, 'open_bus', None)\n"
        "    monkeypatch.setattr('drivers.bus.open_bus', None)\n"
        "    for target in ('drivers.bus.open_bus', 'rig.host.transport.open_bus'):\n"
        "        monkeypatch.setattr(target, None)\n"
        "    with pytest.raises(OSError):\n"
        "        run()\n"
        "    with pytest.raises(SystemExit) as exited:\n"
        "        run()\n"
    )
    modules = _project_modules()
    found = list(patches(written, set(modules)))
    assert found == [
        (3, "drivers.bus", "open_bus"),
        (4, "drivers.bus", "open_bus"),
        (6, "drivers.bus", "open_bus"),
        (6, "rig.host.transport", "open_bus"),
    ]
    elsewhere = bound_elsewhere(modules)
    assert "rig.host.transport" in elsewhere["drivers.bus", "open_bus"]
    assert ("rig.host.transport", "open_bus") not in elsewhere  # patched where it is called: seen
    assert list(wide_catches(written)) == [(7, "OSError"), (9, "SystemExit")]
    (test,) = _functions(written)
    assert not _checks_itself(test.body[2]) and _checks_itself(test.body[4])
