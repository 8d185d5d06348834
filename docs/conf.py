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

#: the reproductions' figures (reproductions.md), drawn by the commands themselves at each build
FIGURES = {
    "dismc.png": ["reproduce", "dismc", "--plot"],
    "dq_current.png": ["reproduce", "dq-current", "--plot"],
    "drives": ["reproduce", "drives", "--plot"],
}


def _figures(app: object) -> None:
    """Run each reproduction with --plot into docs/_generated (kept out of git; a figure already
    there is kept: remove the folder to draw them again; CI builds from a fresh clone)."""
    import subprocess

    out = Path(__file__).parent / "_generated"
    out.mkdir(exist_ok=True)
    for name, argv in FIGURES.items():
        target = out / name
        if target.exists():
            continue
        subprocess.run(
            [sys.executable, "-m", "rig.cli", *argv, str(target)],
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


def setup(app: object) -> None:
    app.connect("builder-inited", _figures)  # type: ignore[attr-defined]
    app.connect("autodoc-process-docstring", _plain_bars)  # type: ignore[attr-defined]
