"""Patching a name where the code under test finds it: in the module that defines it and in every
module that bound it with ``from module import name`` (patching the definition alone leaves those
bindings calling the original, and a test of "nothing opens" sees nothing).

``stand_in(monkeypatch, "drivers.bus.open_bus", refuse)`` replaces the object in every loaded
module that holds it; ``forget(stand_ins)`` (at the test's end) puts the original back in a module
first imported during the test, which bound the stand-in and would keep it for the worker's later
tests (monkeypatch undoes only what it set).
"""

from __future__ import annotations

import importlib
import sys
from types import ModuleType

import pytest

#: the project's packages: where a binding of a patched object is looked for
PACKAGES = ("controllers", "drivers", "plant_emulator", "rig")


def project_modules() -> list[ModuleType]:
    """The project's modules imported so far."""
    return [
        m
        for name, m in list(sys.modules.items())
        if isinstance(m, ModuleType) and name.split(".")[0] in PACKAGES
    ]


def bindings(obj: object) -> list[tuple[ModuleType, str]]:
    """(module, name) of each binding of ``obj`` (the object itself) in a project module."""
    return [(m, name) for m in project_modules() for name, value in list(vars(m).items()) if value is obj]


def stand_in(monkeypatch: pytest.MonkeyPatch, target: str, replacement: object) -> tuple[object, object]:
    """Replace ``target`` ("package.module.name") with ``replacement`` in every module holding it;
    (original, replacement), for ``forget``."""
    module_name, _, name = target.rpartition(".")
    original = getattr(importlib.import_module(module_name), name)
    for module, bound in bindings(original):
        monkeypatch.setattr(module, bound, replacement)
    return original, replacement


def forget(stand_ins: list[tuple[object, object]]) -> None:
    """Put each original back where a module imported during the test bound its stand-in."""
    for original, replacement in stand_ins:
        for module, bound in bindings(replacement):
            setattr(module, bound, original)
