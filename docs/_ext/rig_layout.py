"""The ``rig-layout`` directive: what each package and module of the tree holds, generated from the files.

It walks ``controllers``, ``drivers``, ``plant_emulator`` and ``rig`` from the repository's root, and
gives each package (a folder with an ``__init__.py``) a section: its docstring's first sentence, and
a table of its sub-packages and modules, each with its size in lines and its docstring's first
sentence. The files are read with ``ast``, never imported. A module moved, added or renamed is on
the page at the next build, so the page says where things are without an edit; what it cannot say
by itself, where a new thing goes, is the hand-written part of ``layout.md``.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path
from typing import Any

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("controllers", "drivers", "plant_emulator", "rig")
LONGEST = 200  #: characters of a first sentence shown


def first_sentence(path: Path) -> str:
    """The first sentence of the module's docstring (of ``__init__.py`` for a package), on one line."""
    file = path / "__init__.py" if path.is_dir() else path
    doc = ast.get_docstring(ast.parse(file.read_text(encoding="utf-8"))) or ""
    paragraph = " ".join(doc.strip().split("\n\n")[0].split())
    match = re.match(r"(.+?[^.]\.)(\s|$)", paragraph)  # a full stop, not an ellipsis
    sentence = match.group(1) if match else paragraph
    if len(sentence) > LONGEST:
        sentence = sentence[: sentence.rfind(" ", 0, LONGEST)] + " ..."
    return sentence or "(no docstring)"


def lines(path: Path) -> int:
    """Lines of Python in a module, or in a package and everything below it."""
    files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return sum(len(f.read_text(encoding="utf-8").splitlines()) for f in files)


def children(package: Path) -> list[Path]:
    """A package's sub-packages, then its modules (``__init__``, ``__main__`` and private ones too)."""
    subs = sorted(p for p in package.iterdir() if p.is_dir() and (p / "__init__.py").is_file())
    mods = sorted(p for p in package.glob("*.py") if p.name != "__init__.py")
    return subs + mods


def packages(top: str) -> list[Path]:
    """``top`` and every package below it, depth first."""
    root = ROOT / top
    found = [root]
    for sub in children(root):
        if sub.is_dir():
            found += packages(str(sub.relative_to(ROOT)))
    return found


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown(top: str) -> list[str]:
    """The MyST lines of ``top``'s sections."""
    out: list[str] = []
    for package in packages(top):
        name = f"{package.relative_to(ROOT).as_posix()}/"
        out += [f"### `{name}`", "", _cell(first_sentence(package)), ""]
        out += ["| holds | lines | what it is |", "| --- | --- | --- |"]
        for child in children(package):
            shown = f"{child.name}/" if child.is_dir() else child.name
            out.append(f"| `{shown}` | {lines(child)} | {_cell(first_sentence(child))} |")
        out.append("")
    return out


class RigLayout(SphinxDirective):
    """``rig-layout``: a section per package of the four."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        text = [line for top in PACKAGES for line in markdown(top)]
        for top in PACKAGES:  # a change to any file of the tree rebuilds the page
            for file in (ROOT / top).rglob("*.py"):
                self.env.note_dependency(str(file))
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(text, source="rig-layout"), node)
        return list(node.children)


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("rig-layout", RigLayout)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
