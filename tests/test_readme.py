"""The shell blocks of the README and of the documentation's pages (``docs/*.md``) run as written
(issues 19, 28): each ```sh block is either run here, in a fresh folder beside the examples, with
the installed ``rig`` on PATH, or named below with the reason it is not (a new block must be given
one or the other); what the page says a block does is checked where CLAIMS has a check for it, and a
```text block right after a block that runs is what it prints: each of its lines is a line of the
block's output. A tutorial's blocks (``docs/tutorial-*.md``) run in order as a reader follows the
page in one terminal (a ``cd`` holds for the blocks after it), its first one going into
``tutorial/``, a folder git ignores, which holds everything the page writes. Two blocks in a row
that begin ``# terminal 1`` and ``# terminal 2`` are run together, the first as a server (one
``rig`` command) until the second is done (on a tutorial, after the page's blocks before them): in
the timing tier (a fixed port, processes of their own). A tutorial takes minutes to follow: the
``slow`` tier follows each, and the default run parses each ``rig`` line of every block with rig's
own parser. Every path in the repository a page names in backticks exists, and the README stays a
front door of at most 150 lines."""

from __future__ import annotations

import itertools
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys

import pytest

from rig.cli import build_parser

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: the pages whose blocks and inline commands are tested: the README and the documentation's
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
TERMINALS = ("# terminal 1", "# terminal 2")  #: the first lines of a two-terminal pair
#: what a block that is not run here holds, and why
NOT_HERE = {
    "python3 -m venv": "the virtual environment the commands run in: CI's own first step (.ci/run)",
    "python -m pytest": "the test command itself (CI runs it)",
    "sudo ": "root and a kernel with vcan (the vcan and interop tiers, in CI's VM)",
    "run-in-vcan-vm": "the VM (CI runs it)",
    "vcan0": "two terminals on vcan0 (the vcan tier runs the same)",
    "python -m sphinx": "the documentation's build itself (.ci/run builds it)",
    "mydrive": "the reader's own drive files",
}


def _demo(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """Quick start: errors and chattering of (7.30) with and without its integral, the sign law
    and the cascade, then the run over the emulated CAN bus: ended without a stop, its rms error
    with its unit, (7.30) over the 4096-count encoder within its linear region (no more than the
    alternation or two the load step at the start of the second half makes, the sign law 0 % of
    it), and its run directory under runs/ (samples, summary, plot.png: matplotlib is there).
    The one run of ``rig demo`` in the default tests."""
    out = proc.stdout
    for column in ("max|e|", "rms e", "e_ss", "chatter", "du rms"):
        assert column in out, column
    for law in ("dtsm-7.30 h=16", "dtsm-7.30 h=0", "sign law (6.8)", "cascade VII.D"):
        assert law in out, law
    assert "Over the emulated CAN bus" in out and "stop            none: the run ended" in out
    assert "rms error       " in out and " rad\n" in out  # with its unit
    count = int(out.split("chattering      ")[-1].split()[0])
    assert count <= 2 and "sign law        0 % of the second half" in out and "docs/chattering.md" in out
    (run,) = (folder / "runs").glob("demo-*")
    assert folder / pathlib.Path(out.split("run directory")[1].split()[0]) in (run, run.resolve())
    assert all((run / name).is_file() for name in ("plot.png", "samples.csv", "summary.json"))


def _identify_then_design(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """ "From identification to a run": it says where it wrote identification.json, the a_m and
    b_m the page gives, and the design's --json adds a_m, b_m, lam, dt, input (the Commands
    table). The one run of that identification in the default tests."""
    from tests.test_readme_commands import _identify  # the a_m and b_m the page says it gives

    assert re.search(r"written to runs/identify-voltage-\d{8}-\d{6}/identification\.json", proc.stdout)
    design = json.loads((folder / "design.json").read_text())
    assert {"a_m", "b_m", "lam", "dt", "input", "c_delta"} <= set(design) and design["lam"] == -15
    _identify(proc, folder)


def _two_terminals(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """Getting started: the run over the socketcand link gives the in-process result (its cycles
    and rms error as the page says)."""
    page = " ".join((ROOT / "docs" / "getting-started.md").read_text().split())
    cycles, rms = re.search(r"exactly: (\d+) cycles, rms error ([\d.]+) mrad", page).groups()  # type: ignore[union-attr]
    (run,) = (folder / "runs").glob("dc-servo-position-*")
    summary = json.loads((run / "summary.json").read_text())
    assert summary["cycles"] == int(cycles) and f"{1e3 * summary['rms_error']:.3f}" == rms, summary


#: what a block holds -> the check of what its page says it does
CLAIMS = {
    "rig demo": _demo,
    "rig design dtsm --from-identify": _identify_then_design,
    "rig run --config servo.toml": _two_terminals,
}


def where(path: pathlib.Path) -> str:
    """A page's name as its messages give it: README.md, docs/getting-started.md."""
    return str(path.relative_to(ROOT))


def is_tutorial(line: str) -> bool:
    """Whether the block at ``line`` (``docs/tutorial-servo.md:12``) is a tutorial's."""
    return line.startswith("docs/tutorial-")


def _fenced(text: str) -> list[tuple[int, str, str, str]]:
    """(line, info, body, what follows up to the next fence) of each fenced block of ``text``."""
    fences = list(re.finditer(r"^```([^\n]*)\n(.*?)^```", text, flags=re.M | re.S))
    ends = [m.start() for m in fences[1:]] + [len(text)]
    return [
        (text[: m.start()].count("\n") + 1, m.group(1).strip(), m.group(2), text[m.end() : end])
        for m, end in zip(fences, ends)
    ]


def blocks() -> list[tuple[str, str]]:
    """(where: file and line, text) of every ```sh block of the pages."""
    return [
        (f"{where(path)}:{line}", body)
        for path in DOCS
        for line, info, body, _ in _fenced(path.read_text())
        if info == "sh"
    ]


def shown() -> dict[str, list[str]]:
    """Where a ```sh block is -> the lines of the ```text block right after it (blank lines only
    between): what the page says the block prints."""
    found = {}
    for path in DOCS:
        fenced = _fenced(path.read_text())
        for (line, info, _, between), (_, next_info, body, _) in itertools.pairwise(fenced):
            if info == "sh" and next_info == "text" and not between.strip():
                found[f"{where(path)}:{line}"] = [s.strip() for s in body.splitlines() if s.strip()]
    return found


def _runs_here(block: str) -> bool:
    return not any(key in block for key in NOT_HERE) and not block.startswith(TERMINALS)


def _runnable() -> list[tuple[str, str]]:
    """The blocks run one by one: not a tutorial's, each text once (the same two commands are on
    the README and on Getting started)."""
    seen: set[str] = set()
    found = []
    for line, b in blocks():
        if _runs_here(b) and not is_tutorial(line) and b not in seen:
            seen.add(b)
            found.append((line, b))
    return found


def tutorials() -> dict[str, list[tuple[str, str]]]:
    """Each tutorial page -> its blocks run here, in order."""
    found: dict[str, list[tuple[str, str]]] = {}
    for line, b in blocks():
        if is_tutorial(line):
            found.setdefault(line.split(":")[0], [])
            if _runs_here(b):
                found[line.split(":")[0]].append((line, b))
    return found


def pairs() -> list[tuple[str, str, str]]:
    """(where, terminal 1's block, terminal 2's) of each two-terminal pair."""
    found = blocks()
    return [
        (line, first, second)
        for (line, first), (_, second) in itertools.pairwise(found)
        if first.startswith(TERMINALS[0]) and second.startswith(TERMINALS[1])
    ]


def test_every_block_is_run_or_has_a_reason() -> None:
    runnable = _runnable() + [block for page in tutorials().values() for block in page]
    assert len(blocks()) >= 6 and runnable, blocks()
    paired = {b for _, first, second in pairs() for b in (first, second)}
    alone = [line for line, b in blocks() if b.startswith(TERMINALS) and b not in paired]
    assert not alone and pairs(), f"a terminal block without its other half: {alone}"
    assert any("rig demo" in b for _, b in runnable) and any("rig identify" in b for _, b in runnable)
    assert len(tutorials()) >= 4 and all(tutorials().values()), tutorials()
    tried = [b for _, b in runnable] + [b for _, _, second in pairs() for b in [second]]
    assert all(any(key in b for b in tried) for key in CLAIMS)
    run = {line for line, _ in runnable} | {line for line, _, _ in pairs()}
    # a text block after a block nobody runs would be a claim nobody checks
    unchecked = [line for line in shown() if line not in run and not _is_second(line)]
    assert not unchecked, f"output shown after a block that is not run: {unchecked}"


def _second_of(line: str) -> str:
    """Where the second block is of the two-terminal pair whose first is at ``line``."""
    found = blocks()
    return next(second for (first, _), (second, _) in itertools.pairwise(found) if first == line)


def _is_second(line: str) -> bool:
    """Whether the block at ``line`` is the second of a two-terminal pair (run by the timing tier)."""
    return any(_second_of(first) == line for first, _, _ in pairs())


def check_output(line: str, proc: subprocess.CompletedProcess[str]) -> None:
    """What the page shows after the block at ``line`` is what it printed: each shown line is a
    line of its stdout or stderr (leading and trailing blanks aside)."""
    printed = {s.strip() for s in (proc.stdout + "\n" + proc.stderr).splitlines()}
    missing = [s for s in shown().get(line, []) if s not in printed]
    assert not missing, (
        f"{line}: the page shows lines the block did not print: {missing}\n"
        f"{proc.stdout[-3000:]}\n{proc.stderr[-2000:]}"
    )


def run_here(
    script: str, folder: pathlib.Path, timeout: float = 300, *, link: bool = True
) -> subprocess.CompletedProcess[str]:
    """``script`` run by bash -e in ``folder`` beside the examples, the zoo's device files and the
    tests (with pyproject.toml, their settings), as in a clone's top folder (linked there unless
    ``link`` is false: done before), with the installed ``rig`` on PATH. ``plant_emulator/`` holds
    only ``devices/``: not a package that would shadow the installed one for ``python -c``."""
    if link:
        for name in ("examples", "tests", "pyproject.toml"):
            (folder / name).symlink_to(ROOT / name)
        (folder / "plant_emulator").mkdir()
        (folder / "plant_emulator" / "devices").symlink_to(ROOT / "plant_emulator" / "devices")
    env = {**os.environ, "PATH": f"{pathlib.Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    return subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", script],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


@pytest.mark.parametrize(("line", "block"), _runnable(), ids=[line for line, _ in _runnable()])
def test_the_block_runs_as_written(line: str, block: str, tmp_path: pathlib.Path) -> None:
    # the installation is CI's own first step: the block's install, if any, is not repeated
    script = re.sub(r"python -m pip install [^&\n]*&&\s*", "", block)
    proc = run_here(script, tmp_path)
    assert proc.returncode == 0, f"{line}:\n{script}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    check_output(line, proc)
    for key, check in CLAIMS.items():
        if key in block:
            check(proc, tmp_path)


#: a tutorial's first block: everything the page writes goes into one folder that git ignores
TUTORIAL_FOLDER = "tutorial"
INTO_IT = f"mkdir -p {TUTORIAL_FOLDER} && cd {TUTORIAL_FOLDER}"


def _follow(page: list[tuple[str, str]], folder: pathlib.Path) -> pathlib.Path:
    """Run a tutorial's blocks in order from ``folder``, as in one terminal (each starts where the
    one before it ended), each checked as a block alone is; the folder the last one ended in."""
    here, ended = folder, folder.with_name(f"{folder.name}.pwd")
    for i, (line, block) in enumerate(page):
        proc = run_here(f"trap 'pwd > {shlex.quote(str(ended))}' EXIT\n{block}", here, link=i == 0)
        assert proc.returncode == 0, f"{line}:\n{block}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
        here = pathlib.Path(ended.read_text().strip())
        check_output(line, proc)
        for key, check in CLAIMS.items():
            if key in block:
                check(proc, here)
    return here


def _ignored(name: str) -> bool:
    """Whether the repository's .gitignore ignores the top folder ``name``."""
    lines = (ROOT / ".gitignore").read_text().splitlines()
    return any(line.strip() in (name, f"{name}/", f"/{name}", f"/{name}/") for line in lines)


def test_each_tutorial_writes_into_one_ignored_folder() -> None:
    """A tutorial's first block goes into ``tutorial/`` and .gitignore ignores it (the slow tier
    follows each page and finds nothing else written beside the clone's own files); so do runs/
    and sweeps/, where rig writes a run and a study by default."""
    firsts = {page: blocks[0][1].strip() for page, blocks in tutorials().items()}
    assert firsts and all(first == INTO_IT for first in firsts.values()), firsts
    assert all(_ignored(name) for name in (TUTORIAL_FOLDER, "runs", "sweeps"))


#: what ends a command on a block's line: a redirection, a pipe, the next command
_ENDS = ("||", "&&", "|", ";", "&", ">", ">>", "2>", "2>&1")


def rig_lines(block: str) -> list[list[str]]:
    """The arguments of each line of ``block`` that runs ``rig`` (continuations joined; a
    comment, a redirection or what follows ``||``, ``&&`` or ``|`` left out)."""
    found = []
    for line in block.replace("\\\n", " ").splitlines():
        if not line.strip().startswith("rig "):
            continue
        argv: list[str] = []
        for word in shlex.split(line, comments=True):
            if word in _ENDS or word.startswith((">", "2>")):
                break
            argv.append(word)
        found.append(argv)
    return found


def test_every_rig_line_of_a_block_parses(capsys: pytest.CaptureFixture[str]) -> None:
    """Each ``rig`` line of every block, the tutorials' (followed only in the slow tier) included,
    is accepted by rig's own parser: a renamed option or command fails the default run."""
    lines = [(where, argv) for where, block in blocks() for argv in rig_lines(block)]
    refused = []
    for where, argv in lines:
        try:
            build_parser().parse_args(argv[1:])
        except SystemExit as exit_:
            if exit_.code:
                refused.append(f"{where}: {shlex.join(argv)}: {capsys.readouterr().err.strip()}")
    assert len(lines) > 40 and not refused, "\n".join(refused)


@pytest.mark.slow  # 30 s to 140 s a page under load 10: the default run parses their lines instead
@pytest.mark.timeout(600)  # a tutorial's steps, each a command of seconds (under load, tens)
@pytest.mark.parametrize("page", sorted(tutorials()))
def test_the_tutorial_runs_as_written(page: str, tmp_path: pathlib.Path) -> None:
    """A tutorial's blocks, in order, as in one terminal: each step on what the steps before it
    made, all of it in ``tutorial/`` (beside it only the clone's own files, linked here)."""
    _follow(tutorials()[page], tmp_path)
    linked = ["examples", "plant_emulator", "pyproject.toml", "tests"]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*linked, TUTORIAL_FOLDER])
    assert [p.name for p in (tmp_path / "plant_emulator").iterdir()] == ["devices"]


@pytest.mark.timing  # the server on the page's fixed port (29536), in a process of its own
@pytest.mark.timeout(600)  # a tutorial's steps before the pair, then the pair
@pytest.mark.parametrize(("line", "first", "second"), pairs(), ids=[line for line, _, _ in pairs()])
def test_two_terminals_run_as_written(line: str, first: str, second: str, tmp_path: pathlib.Path) -> None:
    """Terminal 1's one ``rig`` command runs (until Ctrl-C) while terminal 2's block runs as
    written; then Ctrl-C stops it, cleanly."""

    from rig.emulator.spawn import spawn_rig, stop_rig

    (command,) = [c for c in first.splitlines() if c.strip() and not c.startswith("#")]
    argv = shlex.split(command)
    assert argv[0] == "rig", command
    page, at_line = line.split(":")
    before = [(at, b) for at, b in tutorials().get(page, []) if int(at.split(":")[1]) < int(at_line)]
    _follow(before, tmp_path)  # on a tutorial, the steps before the pair, in the same folder
    server, said = spawn_rig(*argv[1:], stderr=True)
    try:
        assert "Ctrl-C" in said, f"{line}: {command}: {said}"
        proc = run_here(second, tmp_path, link=not before)
    finally:
        _out, err = stop_rig(server, timeout=20)
    assert proc.returncode == 0, f"{line}:\n{second}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    assert server.returncode == 0, err
    check_output(_second_of(line), proc)
    for key, check in CLAIMS.items():
        if key in second:
            check(proc, tmp_path)


#: the folders a page may name a path in (`rig/host/loop.py`, `tests/`): each must exist
TREE = ("controllers/", "drivers/", "plant_emulator/", "rig/", "tests/", "examples/", "docs/", ".ci/")


def named_paths() -> list[tuple[str, str]]:
    """(where, path) of each path into the repository that a page names in backticks: a word that
    starts with one of TREE, without a placeholder (<name>, NAME, *)."""
    found = []
    for path in DOCS:
        for m in re.finditer(r"(?<!`)`([^`\s]+)`(?!`)", path.read_text()):
            name = m.group(1).rstrip(".,:;")
            built = name.startswith(("docs/_build", "docs/_generated"))  # made by the docs' build
            if name.startswith(TREE) and not built and not re.search(r"[<>*{}$]|/[A-Z_]+(\.|/|$)|NAME", name):
                found.append((f"{where(path)}:{path.read_text()[: m.start()].count(chr(10)) + 1}", name))
    return found


def test_the_paths_the_pages_name_exist() -> None:
    """A module moved or renamed without its mention on a page fails here, naming both: the pages
    (the layout's "where a new thing goes" most of all) stay true as the tree changes."""
    found = named_paths()
    missing = [f"{at}: `{name}`" for at, name in found if not (ROOT / name.split("::")[0]).exists()]
    assert len(found) > 30 and not missing, "no such path in the repository:\n" + "\n".join(missing)


#: the README's commands, verbatim: a virtual environment of the clone's own, then the two
#: commands in it; CI makes the same environment and runs the last (.ci/run)
COMMANDS = (
    "python3 -m venv .venv && . .venv/bin/activate",
    "python -m pip install -e . && rig demo",
    "python -m pip install -e '.[test]' && python -m pytest",
)


def test_the_readme_is_a_front_door() -> None:
    """The README is at most 150 lines: what the toolkit is, its commands as written (a virtual
    environment first, made and entered as .ci/run does before it installs, then the two
    commands in it, the second the one .ci/run runs), one picture that is in the repository, and
    links into the documentation, each to a page that exists; the rest is on the pages."""
    text = (ROOT / "README.md").read_text()
    readme_blocks = [b.strip() for at, b in blocks() if at.startswith("README.md:")]
    assert len(text.splitlines()) <= 150, f"README.md has {len(text.splitlines())} lines: move some to docs/"
    assert readme_blocks == list(COMMANDS), readme_blocks
    ci = (ROOT / ".ci" / "run").read_text()
    made, entered = COMMANDS[0].split(" && ")
    assert made in ci and entered in ci and ci.index(entered) < ci.index("pip install") and COMMANDS[2] in ci
    (picture,) = re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text)
    assert (ROOT / picture).is_file(), picture
    links = re.findall(r"\]\((docs/[^)#\s]+)", text)
    assert len(links) >= 10 and all((ROOT / link).is_file() for link in links), links
