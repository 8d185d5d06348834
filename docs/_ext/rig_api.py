"""The ``rig-api`` directive: the API reference, every module of the four packages by autodoc.

It walks ``controllers``, ``drivers``, ``plant_emulator`` and ``rig`` (``pkgutil``) and gives
each module a section with ``automodule`` and its members: a module added to a package is in
the reference without an edit here.
"""

from __future__ import annotations

import importlib
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


class RigApi(SphinxDirective):
    """``rig-api PACKAGE``: a section per module of PACKAGE."""

    required_arguments = 1

    def run(self) -> list[nodes.Node]:
        lines = []
        for name in modules(self.arguments[0]):
            # the page is MyST: its nested content is parsed as MyST too
            lines += [f"## {name}", "", f"```{{automodule}} {name}", ":members:", "```", ""]
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(lines, source="rig-api"), node)
        return node.children


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("rig-api", RigApi)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
