"""The documentation site as a reader gets it (issue 37 item 5): the built HTML, not its sources.

The API pages render autodoc's directives (a signature, ``dt.sig``, for every documented class and
function of each package, each described once) and never show them as text; the CLI page keeps
``--json`` as typed; the architecture page the code's docstrings cite is in the docs.

The HTML is the site CI builds (``RIG_DOCS_HTML=docs/_build/html``, after .ci/run's
``python -m sphinx -W``), or, without it, built here into a temporary folder with the same
options: ``python -m pytest -m docs -n 0`` (needs the docs extra; minutes under load).
"""

from __future__ import annotations

import html
import importlib
import importlib.util
import inspect
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
#: the packages of the API pages (docs/_ext/rig_api.py's PACKAGES, which needs Sphinx to import)
PACKAGES = ("controllers", "drivers", "plant_emulator", "rig")

#: a rendered signature of autodoc's: its anchor is the object's full name
SIGNATURE = re.compile(r'<dt class="sig sig-object py" id="([\w.]+)">')
#: a directive left as text: reStructuredText a MyST page did not read
RAW = re.compile(r"<p>[^<]*\.\. (py:|auto)")
#: a cross-reference to a Python object that Sphinx resolved (a type in a signature or a field list,
#: a role in a docstring): a link to the object's anchor, titled with its full name
XREF = re.compile(r'<a class="reference internal" href="[^"]*#([\w.]+)" title="\1"')


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """The built site: CI's (RIG_DOCS_HTML) or one built here with warnings as errors."""
    given = os.environ.get("RIG_DOCS_HTML")
    if given:
        return pathlib.Path(given)
    out = tmp_path_factory.mktemp("html")
    cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "docs", str(out)]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out


def documented(package: str) -> set[str]:
    """The full names autodoc describes for ``package``: each module's own public classes and
    functions with a docstring (re-exports are described where they are defined)."""
    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    import rig_api

    assert rig_api.PACKAGES == PACKAGES
    names = set()
    for name in rig_api.modules(package):
        module = importlib.import_module(name)
        exported = getattr(module, "__all__", None)
        for attr, obj in vars(module).items():
            if not (inspect.isclass(obj) or inspect.isfunction(obj)) or obj.__module__ != name:
                continue
            public = attr in exported if exported is not None else not attr.startswith("_")
            if public and inspect.getdoc(obj):
                names.add(f"{name}.{attr}")
    return names


@pytest.mark.docs
@pytest.mark.parametrize("package", PACKAGES)
def test_api_page_renders(site: pathlib.Path, package: str) -> None:
    """Every documented class and function of the package has a rendered signature on its page,
    with resolved cross-references, and no directive is left as a paragraph."""
    page = (site / f"api-{package}.html").read_text()
    rendered = set(SIGNATURE.findall(page))
    missing = documented(package) - rendered
    assert not missing, f"api-{package}.html renders no signature of {sorted(missing)[:20]}"
    assert not RAW.findall(page), f"api-{package}.html shows a directive as text"
    assert "Parameters" in page and len(XREF.findall(page)) > 10, f"api-{package}.html: no cross-references"


#: a rendered class, exception or function (not an attribute that aliases one): its kind, its anchor
DEFINITION = re.compile(
    r'<dl class="py (class|exception|function)">\s*<dt class="sig sig-object py" id="([\w.]+)">'
)


def is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:  # a name inside a module that is not a package
        return False


@pytest.mark.docs
def test_every_object_described_once(site: pathlib.Path) -> None:
    """One canonical place per object: each class and function is described under the name of
    the module that defines it (a package re-exporting it only links there), and once."""
    seen: dict[str, str] = {}
    for package in PACKAGES:
        for _, anchor in DEFINITION.findall((site / f"api-{package}.html").read_text()):
            module, name = anchor.rsplit(".", 1)
            while not is_module(module):  # a class inside a class
                module, outer = module.rsplit(".", 1)
                name = f"{outer}.{name}"
            obj: object = importlib.import_module(module)
            for part in name.split("."):
                obj = getattr(obj, part)
            assert getattr(obj, "__module__", None) == module, f"{anchor} is a re-export"
            assert anchor not in seen, f"{anchor} on api-{package}.html and {seen[anchor]}"
            seen[anchor] = f"api-{package}.html"


@pytest.mark.docs
def test_options_render_as_typed(site: pathlib.Path) -> None:
    """The CLI reference's prose keeps ``--json`` as typed (smart quotes would make it an en dash)."""
    text = html.unescape(re.sub(r"<[^>]+>", "", (site / "cli.html").read_text()))
    assert "--json" in text
    assert not re.search("[\u2013\u2014]json", text), "an option rendered with a dash: smart quotes"


@pytest.mark.docs
def test_architecture_page(site: pathlib.Path) -> None:
    """The architecture the docstrings cite is a page of the site."""
    assert "One cycle" in (site / "architecture.html").read_text()


def test_cited_pages_exist() -> None:
    """Every docs page a docstring or comment of the code cites (``docs/NAME.md``) exists, and none
    cites the team's architecture file outside the repository (docs/architecture.md is the page)."""
    outside = "ARCHITECTURE" + ".md"  # spelt apart: this test is no citation of it
    sources = [p for d in (*PACKAGES, "tests") for p in (ROOT / d).rglob("*.py")]
    for path in sources:
        text = path.read_text()
        assert outside not in text, path
        for page in re.findall(r"docs/([a-z][a-z0-9_-]*\.md)", text):
            assert (ROOT / "docs" / page).is_file(), f"{path.relative_to(ROOT)} cites docs/{page}"
