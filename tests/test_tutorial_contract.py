"""docs/tutorial-commissioning.md's step 4: the driver's contract tests, run as the page gives
them (``python -m pytest -m hardware tests/drivers/test_drive_contract.py ...`` in a clone's top
folder: the suite's own worker count, a relative ``--eds``), pass against every twin of the zoo
served by ``rig emulate --device NAME`` in a process of its own. The page's own pair (the EPOS4
twin on 127.0.0.1:29536) is run as written by tests/test_readme.py's two-terminal test; here each
twin in turn, on a free port, with its EDS and the factor it lacks."""

from __future__ import annotations

import os
import pathlib
import re

import pytest

from plant_emulator.device_profile import device_profile, zoo
from rig.emulator.spawn import spawn_emulator, stop_rig
from tests.drivers.test_drive_contract import ZOO_UNITS
from tests.test_readme import ROOT, blocks, run_here

PAGE = "docs/tutorial-commissioning.md"


def contract_block() -> str:
    """The page's terminal-2 block that runs the contract tests."""
    (block,) = [
        b
        for at, b in blocks()
        if at.startswith(PAGE) and b.startswith("# terminal 2") and "test_drive_contract" in b
    ]
    return block


@pytest.mark.timing  # a server and a pytest session of their own, on the wall clock
@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", sorted(zoo()))
def test_the_contract_passes_against_every_twin(name: str, tmp_path: pathlib.Path) -> None:
    page = " ".join((ROOT / PAGE).read_text().split())
    assert "passes against every twin of the zoo, each served by `rig emulate --device NAME`" in page
    block = contract_block()
    eds = device_profile(name).eds
    inside = eds.is_relative_to(ROOT / "plant_emulator" / "devices")  # linked beside the tests
    script = block.replace(
        "plant_emulator/devices/epos4.eds", os.path.relpath(eds, ROOT) if inside else str(eds)
    )
    units = "".join(f" --units {k}={v:g}" for k, v in ZOO_UNITS.get(name, {}).items())
    if units:
        assert f"`{units.strip()}`" in page, units  # the page says which twin needs what
    server, port = spawn_emulator("--device", name)
    try:
        proc = run_here(f"{script.rstrip()} --port {port}{units}", tmp_path, timeout=240)
    finally:
        stop_rig(server, timeout=20)
    tail = proc.stdout[-3000:] + proc.stderr[-2000:]
    assert proc.returncode == 0, tail
    summary = proc.stdout.strip().splitlines()[-1]
    passed = re.search(r"(\d+) passed", summary)
    assert passed and int(passed[1]) >= 3 and not re.search(r"failed|skipped|error", summary), tail
