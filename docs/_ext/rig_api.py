"""The ``rig-api`` directive: the API reference, every module of the four packages by autodoc.

It walks ``controllers``, ``drivers``, ``plant_emulator`` and ``rig`` (``pkgutil``) and gives
each module a section with ``automodule`` and its members: a module added to a package is in
the reference without an edit here.

autodoc writes reStructuredText (``.. py:class::`` ...), which a MyST page reads as a paragraph:
each section's directives are in an ``eval-rst`` block. A class or function that a module only
re-exports (in its ``__all__``, defined elsewhere) is described once, where it is defined; the
module that re-exports it lists it with a link there.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from typing import Any

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

PACKAGES = ("controllers", "drivers", "plant_emulator", "rig")


def modules(package: str) -> list[str]:
    """``package`` and every module below it, sorted."""
    root = importlib.import_module(package)
    found = [package]
    for info in pkgutil.walk_packages(root.__path__, prefix=f"{package}."):
        if not info.name.rsplit(".", 1)[-1].startswith("_") or info.name.endswith("__main__"):
            found.append(info.name)
    return sorted(n for n in found if not n.endswith("__main__"))


def reexports(name: str) -> dict[str, str]:
    """The classes and functions module ``name`` exports (``__all__``) but does not define:
    exported name -> where it is defined (``module.qualname``)."""
    module = importlib.import_module(name)
    found = {}
    for export in getattr(module, "__all__", ()):
        obj = getattr(module, export)
        home = getattr(obj, "__module__", name)
        if (inspect.isclass(obj) or inspect.isfunction(obj)) and home != name:
            found[export] = f"{home}.{obj.__qualname__}"
    return found


def section(name: str) -> list[str]:
    """The MyST lines of module ``name``'s section."""
    lines = [f"## {name}", "", "```{eval-rst}", f".. automodule:: {name}", "   :members:"]
    elsewhere = reexports(name)
    if elsewhere:
        lines += [f"   :exclude-members: {', '.join(elsewhere)}", ""]
        links = ", ".join(f":py:obj:`{export} <{home}>`" for export, home in elsewhere.items())
        lines += [f"   Re-exported here (described where they are defined): {links}."]
    return [*lines, "```", ""]


class RigApi(SphinxDirective):
    """``rig-api PACKAGE``: a section per module of PACKAGE."""

    required_arguments = 1

    def run(self) -> list[nodes.Node]:
        lines = [line for name in modules(self.arguments[0]) for line in section(name)]
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(lines, source="rig-api"), node)
        return node.children


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("rig-api", RigApi)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
