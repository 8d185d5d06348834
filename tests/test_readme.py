"""The shell blocks of the README and of the documentation's pages (``docs/*.md``) run as written
(issues 19, 28): each ```sh block is either run here, in a fresh folder beside the examples, with
the installed ``rig`` on PATH, or named below with the reason it is not (a new block must be given
one or the other); what the page says a block does is checked where CLAIMS has a check for it.
Two blocks in a row that begin ``# terminal 1`` and ``# terminal 2`` are run together, the first
as a server (one ``rig`` command) until the second is done: in the timing tier (a fixed port,
processes of their own)."""

from __future__ import annotations

import itertools
import json
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: the pages whose blocks and inline commands are tested: the README and the documentation's
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
TERMINALS = ("# terminal 1", "# terminal 2")  #: the first lines of a two-terminal pair
#: what a block that is not run here holds, and why
NOT_HERE = {
    "python -m pytest": "the test command itself (CI runs it)",
    "sudo ": "root and a kernel with vcan (the vcan and interop tiers, in CI's VM)",
    "run-in-vcan-vm": "the VM (CI runs it)",
    "vcan0": "two terminals on vcan0 (the vcan tier runs the same)",
    "python -m sphinx": "the documentation's build itself (.ci/run builds it)",
    "mydrive": "the reader's own drive files",
}


def _demo(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """Quick start: errors and chattering of (7.30) with and without its integral, the sign law
    and the cascade, and a run directory under runs/ (its plot.png: matplotlib is there)."""
    for column in ("max|e|", "rms e", "e_ss", "chatter", "du rms"):
        assert column in proc.stdout, column
    for law in ("dtsm-7.30 h=16", "dtsm-7.30 h=0", "sign law (6.8)", "cascade VII.D"):
        assert law in proc.stdout, law
    (run,) = (folder / "runs").glob("demo-*")
    assert (run / "plot.png").is_file()


def _identify_then_design(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """ "From identification to a run": it says where it wrote identification.json, and the
    design's --json adds a_m, b_m, lam, dt, input (the Commands table)."""
    assert re.search(r"written to runs/identify-voltage-\d{8}-\d{6}/identification\.json", proc.stdout)
    design = json.loads((folder / "design.json").read_text())
    assert {"a_m", "b_m", "lam", "dt", "input", "c_delta"} <= set(design) and design["lam"] == -15


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


def blocks() -> list[tuple[str, str]]:
    """(where: file and line, text) of every ```sh block of the pages."""
    found = []
    for path in DOCS:
        text = path.read_text()
        found += [
            (f"{where(path)}:{text[: m.start()].count(chr(10)) + 1}", m.group(1))
            for m in re.finditer(r"^```sh\n(.*?)^```", text, flags=re.M | re.S)
        ]
    return found


def _runnable() -> list[tuple[str, str]]:
    return [
        (line, b)
        for line, b in blocks()
        if not any(key in b for key in NOT_HERE) and not b.startswith(TERMINALS)
    ]


def pairs() -> list[tuple[str, str, str]]:
    """(where, terminal 1's block, terminal 2's) of each two-terminal pair."""
    found = blocks()
    return [
        (line, first, second)
        for (line, first), (_, second) in itertools.pairwise(found)
        if first.startswith(TERMINALS[0]) and second.startswith(TERMINALS[1])
    ]


def test_every_block_is_run_or_has_a_reason() -> None:
    runnable = _runnable()
    assert len(blocks()) >= 6 and runnable, blocks()
    paired = {b for _, first, second in pairs() for b in (first, second)}
    alone = [line for line, b in blocks() if b.startswith(TERMINALS) and b not in paired]
    assert not alone and pairs(), f"a terminal block without its other half: {alone}"
    assert any("rig demo" in b for _, b in runnable) and any("rig identify" in b for _, b in runnable)
    tried = [b for _, b in runnable] + [b for _, _, second in pairs() for b in [second]]
    assert all(any(key in b for b in tried) for key in CLAIMS)


def run_here(
    script: str, folder: pathlib.Path, timeout: float = 300, *, link: bool = True
) -> subprocess.CompletedProcess[str]:
    """``script`` run by bash -e in ``folder`` beside the examples (linked there unless ``link`` is
    false: done before), with the installed ``rig`` on PATH."""
    if link:
        (folder / "examples").symlink_to(ROOT / "examples")
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
    for key, check in CLAIMS.items():
        if key in block:
            check(proc, tmp_path)


@pytest.mark.timing  # the server on the page's fixed port (29536), in a process of its own
@pytest.mark.parametrize(("line", "first", "second"), pairs(), ids=[line for line, _, _ in pairs()])
def test_two_terminals_run_as_written(line: str, first: str, second: str, tmp_path: pathlib.Path) -> None:
    """Terminal 1's one ``rig`` command runs (until Ctrl-C) while terminal 2's block runs as
    written; then Ctrl-C stops it, cleanly."""
    import shlex

    from rig.emulator.spawn import spawn_rig, stop_rig

    (command,) = [c for c in first.splitlines() if c.strip() and not c.startswith("#")]
    argv = shlex.split(command)
    assert argv[0] == "rig", command
    server, said = spawn_rig(*argv[1:], stderr=True)
    try:
        assert "Ctrl-C" in said, f"{line}: {command}: {said}"
        proc = run_here(second, tmp_path)
    finally:
        _out, err = stop_rig(server, timeout=20)
    assert proc.returncode == 0, f"{line}:\n{second}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    assert server.returncode == 0, err
    for key, check in CLAIMS.items():
        if key in second:
            check(proc, tmp_path)
