"""The README's shell blocks run as written (issue 19): each ```sh block is either run here, in
a fresh folder beside the examples, with the installed ``rig`` on PATH, or named below with
the reason it is not (a new block must be given one or the other); what the README says a block
does is checked where CLAIMS has a check for it."""

from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: what a block that is not run here holds, and why
NOT_HERE = {
    "python -m pytest": "the test command itself (CI runs it)",
    "sudo ": "root and a kernel with vcan (the vcan and interop tiers, in CI's VM)",
    "run-in-vcan-vm": "the VM (CI runs it)",
    "# terminal 1": "two terminals on vcan0 (the vcan tier runs the same)",
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


#: what a block holds -> the check of what the README says it does
CLAIMS = {"rig demo": _demo, "rig design dtsm --from-identify": _identify_then_design}


def blocks() -> list[tuple[int, str]]:
    """(line, text) of every ```sh block."""
    text = (ROOT / "README.md").read_text()
    return [
        (text[: m.start()].count("\n") + 1, m.group(1))
        for m in re.finditer(r"^```sh\n(.*?)^```", text, flags=re.M | re.S)
    ]


def _runnable() -> list[tuple[int, str]]:
    return [(line, b) for line, b in blocks() if not any(key in b for key in NOT_HERE)]


def test_every_block_is_run_or_has_a_reason() -> None:
    runnable = _runnable()
    assert len(blocks()) >= 6 and runnable, blocks()
    assert any("rig demo" in b for _, b in runnable) and any("rig identify" in b for _, b in runnable)
    assert all(any(key in b for _, b in runnable) for key in CLAIMS)


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


@pytest.mark.parametrize(("line", "block"), _runnable(), ids=lambda v: str(v) if isinstance(v, int) else "")
def test_the_block_runs_as_written(line: int, block: str, tmp_path: pathlib.Path) -> None:
    # the installation is CI's own first step: the block's install, if any, is not repeated
    script = re.sub(r"python -m pip install [^&\n]*&&\s*", "", block)
    proc = run_here(script, tmp_path)
    assert proc.returncode == 0, (
        f"README line {line}:\n{script}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    )
    for key, check in CLAIMS.items():
        if key in block:
            check(proc, tmp_path)
