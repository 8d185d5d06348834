"""Layer rules of docs/architecture.md and each package's public ``__all__``."""

from __future__ import annotations

import ast
import importlib
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ALLOWED = {
    "controllers": {"numpy", "scipy", "controllers"},
    "drivers": {"can", "canopen", "pymodbus", "serial", "drivers"},
    "plant_emulator": {
        "numpy",
        "scipy",
        "can",
        "canopen",
        "pymodbus",
        "serial",
        "drivers",
        "plant_emulator",
    },
}
STDLIB_IO = {"logging", "time", "socket", "os", "subprocess", "threading"}


def _imports(path: pathlib.Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_imports_go_one_way(package: str) -> None:
    project = {"rig", "drivers", "controllers", "plant_emulator"}
    for path in (ROOT / package).rglob("*.py"):
        for name in _imports(path) & project:
            assert name in ALLOWED[package], f"{path.relative_to(ROOT)} imports {name}"


def test_controllers_do_no_io() -> None:
    for path in (ROOT / "controllers").rglob("*.py"):
        bad = _imports(path) & STDLIB_IO
        assert not bad, f"{path.relative_to(ROOT)} imports {bad}"


@pytest.mark.parametrize(
    "module",
    [
        p.relative_to(ROOT).with_suffix("").as_posix().replace("/", ".")
        for pkg in ("rig", "drivers", "controllers", "plant_emulator")
        for p in sorted((ROOT / pkg).glob("*.py"))
        if p.name not in ("__init__.py", "__main__.py")
    ],
)
def test_every_module_declares_all_and_it_resolves(module: str) -> None:
    mod = importlib.import_module(module)
    assert hasattr(mod, "__all__"), f"{module} has no __all__"
    for name in mod.__all__:
        assert hasattr(mod, name), f"{module}.__all__ names missing {name}"
