"""The tree's levels (issue 28 item 4): imports go one way, from a level to the levels below it.

Every import counts, at module level or inside a function (a lazy import is still a dependency),
read from the source with ``ast``. The levels, lowest first (``LEVELS``):

- the libraries: ``drivers`` (the wire, and what the host and the emulator share: time profiles,
  CAN bit timing, typed keys; a run on a real bus loads no emulator module), then
  ``controllers`` (the papers' laws as pure arithmetic) and ``plant_emulator`` (the other side of the wire);
- ``rig.laws``: the control laws a run steps, each with its typed parameters, and the papers'
  constants they default to;
- ``rig.config``: a run's configuration, read and checked once at load (a ``[controller]``
  table's keys are its law's parameters);
- ``rig.report`` and ``rig.live``: what a run's samples become (metrics, summaries, plots, the live
  view);
- ``rig.host``: one run on a bus (the session, the loop, the recorder, the safety);
- what builds runs: the studies and the commands' work (``rig.faults``, ``rig.commission``,
  ``rig.identify``, ``rig.papers``, ``rig.sweep``, ``rig.bench``, ``rig.emulator``, ``rig.doctor``);
- ``rig.cli``: the command line, on top.

A package of rig/ is ``rig.NAME``; only the package's entry points sit loose at rig/'s top. Two
packages of one level may import each other one way, never in a circle; neither may the modules of
``plant_emulator``, ``drivers`` or ``controllers``, nor the modules inside a package of rig/
(``CIRCLES``: today's, which may only shrink). A new package gets a level here: the test fails for
one it does not know.
"""

from __future__ import annotations

import ast
import pathlib
from collections import defaultdict

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = ("rig", "drivers", "controllers", "plant_emulator")

#: lowest first; a group may import from its own level and the levels below it
LEVELS: tuple[tuple[str, ...], ...] = (
    ("drivers",),
    ("controllers", "plant_emulator"),
    ("rig.laws",),
    ("rig.config",),
    ("rig.report", "rig.live"),
    ("rig.host",),
    (
        "rig.faults",
        "rig.commission",
        "rig.identify",
        "rig.papers",
        "rig.sweep",
        "rig.bench",
        "rig.emulator",
        "rig.doctor",
        "rig.view",
    ),
    ("rig.cli",),
)

#: the modules allowed loose at rig/'s top: its entry points
ENTRY_POINTS = {"rig", "rig.__main__"}

#: modules still loose at rig/'s top, each with the group whose level it is held to until it moves
LOOSE: dict[str, str] = {}

#: imports that break the levels today, (importer, imported) module by module: each is a debt
ALLOWED: set[tuple[str, str]] = set()

#: circles of modules inside a package of rig/ today, each a debt that may only shrink: loop.py's
#: summary reads the loop it describes (its ``HostLoop``, by annotation)
CIRCLES: dict[str, list[list[str]]] = {}


def modules() -> dict[str, pathlib.Path]:
    """Every module of the four packages by dotted name (a package by its own name)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def _resolve(name: str, known: dict[str, pathlib.Path]) -> str | None:
    """The module of ours ``name`` is, or is in (an attribute of a module), or None."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def imports() -> dict[str, set[str]]:
    """Module -> the modules of ours it imports anywhere in its source (lazy imports included).

    ``from package import name`` is an import of ``package.name`` when that is a module (the
    package's ``__init__`` is then imported as its parent, which every module of it does).
    """
    known = modules()
    graph: dict[str, set[str]] = {}
    for name, path in known.items():
        out: set[str] = set()
        is_package = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = name.split(".") if is_package else name.split(".")[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    source = ".".join(base + ([node.module] if node.module else []))
                else:
                    source = node.module or ""
                for alias in node.names:
                    sub = f"{source}.{alias.name}"
                    targets.append(sub if sub in known else source)
            for target in targets:
                resolved = _resolve(target, known)
                if resolved and resolved != name:
                    out.add(resolved)
        graph[name] = out
    return graph


def group(module: str) -> str:
    """``rig.NAME`` for a module of rig/ (a loose one: the group ``LOOSE`` holds it to), else its
    top package."""
    parts = module.split(".")
    if parts[0] != "rig" or module in ENTRY_POINTS:
        return parts[0]
    return LOOSE.get(module, f"rig.{parts[1]}")


def level(name: str) -> int:
    for i, names in enumerate(LEVELS):
        if name in names:
            return i
    raise AssertionError(f"{name} has no level: give it one in tests/test_layers.py LEVELS")


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _allowed(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    return {a: {b for b in bs if (a, b) not in ALLOWED} for a, bs in graph.items()}


def test_no_module_circle_in_the_libraries() -> None:
    graph = _allowed(imports())
    for package in ("plant_emulator", "drivers", "controllers"):
        inside = {
            a: {b for b in bs if b.split(".")[0] == package and b != package}
            for a, bs in graph.items()
            if a.split(".")[0] == package
        }
        found = cycles(inside)
        assert found == [], f"{package}: modules importing each other in a circle: {found}"


def circles_inside(graph: dict[str, set[str]]) -> dict[str, list[list[str]]]:
    """Each package of rig/ (``rig.NAME``) -> the circles of its modules importing each other
    (every import, lazy and annotation-only ones included; the package's own ``__init__`` aside)."""
    found = {}
    for package in sorted({group(m) for m in graph if m.startswith("rig.")}):
        inside = {
            a: {b for b in bs if group(b) == package and b != package}
            for a, bs in graph.items()
            if group(a) == package and a != package
        }
        if circles := cycles(inside):
            found[package] = circles
    return found


def test_no_module_circle_inside_a_package_of_rig() -> None:
    """A module of a package imports another of it one way: schema <-> controller, view <->
    window, spec <-> point were circles (issue 37 item 4); ``CIRCLES`` lists what is left, which
    may only shrink."""
    found = circles_inside(_allowed(imports()))
    new = {p: [c for c in cs if c not in CIRCLES.get(p, [])] for p, cs in found.items()}
    assert not any(new.values()), f"modules of a package importing each other in a circle: {new}"
    gone = {p: [c for c in cs if c not in found.get(p, [])] for p, cs in CIRCLES.items()}
    assert not any(gone.values()), f"CIRCLES lists circles that are gone: take them out: {gone}"


def test_a_circle_inside_a_package_is_found() -> None:
    graph = {
        "rig.x.a": {"rig.x.b"},
        "rig.x.b": {"rig.x.a", "rig.x"},
        "rig.x": {"rig.x.a"},
        "rig.y.c": {"rig.x.a"},
    }
    assert circles_inside(graph) == {"rig.x": [["rig.x.a", "rig.x.b"]]}


def test_no_circle_between_the_packages_of_rig() -> None:
    between: dict[str, set[str]] = defaultdict(set)
    for a, bs in _allowed(imports()).items():
        for b in bs:
            if a.startswith("rig") and b.startswith("rig") and group(a) != group(b):
                between[group(a)].add(group(b))
    found = cycles(between)
    assert found == [], f"packages of rig/ importing each other in a circle: {found}"


def test_imports_go_down_the_levels() -> None:
    wrong = sorted(
        f"{a} -> {b} ({group(a)} is below {group(b)})"
        for a, bs in _allowed(imports()).items()
        for b in bs
        if group(a) != group(b) and level(group(a)) < level(group(b))
    )
    assert wrong == [], (
        "imports up the levels (move what the lower one needs down to it, or what imports up "
        "to a level above):\n" + "\n".join(wrong)
    )


def test_only_the_entry_points_sit_at_the_top_of_rig() -> None:
    loose = {f"rig.{p.stem}" if p.name != "__init__.py" else "rig" for p in (ROOT / "rig").glob("*.py")}
    new = sorted(loose - ENTRY_POINTS - set(LOOSE))
    assert new == [], f"loose at rig/'s top: {new}: put each in the package of its concern"
    moved = sorted(set(LOOSE) - loose)
    assert moved == [], f"LOOSE names modules that moved: {moved}: take them out"


def test_the_allowances_are_still_needed() -> None:
    graph = imports()
    stale = sorted(f"{a} -> {b}" for a, b in ALLOWED if b not in graph.get(a, set()))
    assert stale == [], "ALLOWED holds imports that are gone: take them out"
