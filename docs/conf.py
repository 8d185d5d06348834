"""Sphinx configuration of drive-rig's documentation (``python -m sphinx -W -b html docs docs/_build``)."""

from __future__ import annotations

import os
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "drive-rig"
author = "drive-rig developers"
release = metadata.version("drive-rig")
version = release
extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "rig_api",
    "rig_cli",
    "rig_config",
    "rig_layout",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "_generated"]
myst_enable_extensions = ["colon_fence"]
myst_heading_anchors = 3
napoleon_google_docstring = False
napoleon_numpy_docstring = True
autodoc_member_order = "bysource"
autodoc_typehints = "description"
html_theme = "alabaster"
html_title = f"drive-rig {release}"
nitpicky = False
# What is typed renders as typed: docutils' smart quotes would turn ``--json`` in prose (the CLI
# reference's help texts, generated from argparse) into an en dash and quotes into curly ones, which
# fail when copied into a shell.
smartquotes = False

#: the reproductions' figures (reproductions.md), drawn by the commands themselves at each build
FIGURES = {
    "dismc.png": ["reproduce", "dismc"],
    "dq-current.png": ["reproduce", "dq-current"],
    "drives": ["reproduce", "drives"],  # a folder of figures
}


def _figures(app: object) -> None:
    """Run each reproduction with --plot docs/_generated (a folder: kept out of git; a figure
    already there is kept: remove the folder to draw them again; CI builds from a fresh clone)."""
    import subprocess

    out = Path(__file__).parent / "_generated"
    out.mkdir(exist_ok=True)
    for name, argv in FIGURES.items():
        target = out / name
        if target.exists():
            continue
        subprocess.run(
            [sys.executable, "-m", "rig.cli", *argv, "--plot", str(out if target.suffix else target)],
            check=True,
            stdout=subprocess.DEVNULL,
            env={**os.environ, "MPLBACKEND": "Agg"},
        )


def _plain_bars(*args: Any) -> None:
    """The docstrings write |e| for an absolute value, which reStructuredText reads as a
    substitution: each | outside a ``literal`` becomes a plain one (autodoc-process-docstring:
    its last argument, the lines, is changed in place)."""
    import re

    lines: list[str] = args[-1]

    for i, line in enumerate(lines):
        parts = re.split(r"(``.*?``)", line)
        lines[i] = "".join(p if p.startswith("``") else p.replace("|", "\\|") for p in parts)


def _numpydoc_but_attributes(app: Any, what: str, *args: Any) -> None:
    """napoleon for functions', classes' and modules' docstrings (numpydoc sections), not for
    attributes': their ``#:`` comments are prose, which napoleon would split at the first ``: ``
    into a type and a description (``[s]: the period`` shown as of type ``[s]``)."""
    from sphinx.ext.napoleon import _process_docstring

    if what not in ("attribute", "data", "property"):
        _process_docstring(app, what, *args)


def setup(app: Any) -> None:
    from sphinx.ext.napoleon import _process_docstring

    app.connect("builder-inited", _figures)
    app.connect("autodoc-process-docstring", _plain_bars)
    listeners = app.events.listeners["autodoc-process-docstring"]
    (napoleon,) = (lsn for lsn in listeners if lsn.handler is _process_docstring)
    app.disconnect(napoleon.id)
    app.connect("autodoc-process-docstring", _numpydoc_but_attributes, priority=napoleon.priority)
