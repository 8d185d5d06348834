"""The dual-axis examples as their header gives them in two terminals: ``rig emulate --device
dual-axis --time lockstep`` in a process of its own behind socketcand, and ``rig run --config`` of
the example (its ``[bus]`` and ``[run] period``; only the port is the free one the emulator took)
in another. In lock-step the two processes give the in-process run (``--emulate``) bit for bit."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.host.rundir import read_samples

ROOT = pathlib.Path(__file__).resolve().parents[2]
DURATION = "0.2"  #: [s] 500 cycles of the twin's 0.4 ms: both axes moving from 0.1 s


def _rig_run(config: pathlib.Path, *extra: str) -> dict[str, object]:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "rig.cli",
            "run",
            "--config",
            str(config),
            "--duration",
            DURATION,
            "--json",
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=110,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    summary: dict[str, object] = json.loads(proc.stdout)
    return summary


@pytest.mark.timeout(240)
@pytest.mark.parametrize("example", ["dual_axis_speed.toml", "dual_axis_ip.toml"])
def test_a_dual_axis_example_runs_against_the_twin_in_another_process(
    example: str, tmp_path: pathlib.Path
) -> None:
    text = (ROOT / "examples" / example).read_text()
    text = text.replace('"../plant_emulator/', json.dumps(f"{ROOT}/plant_emulator/")[:-1])  # copied elsewhere
    assert "\nport = 29536\n" in text and "\nperiod = 0.0004 " in text  # what the header's run needs
    wire_dir, here_dir = tmp_path / "wire", tmp_path / "here"
    emulator, port = spawn_emulator("--device", "dual-axis", "--time", "lockstep")
    try:
        wire_cfg = tmp_path / "wire.toml"
        wire_cfg.write_text(
            text.replace('output = "runs"', f"output = {json.dumps(str(wire_dir))}").replace(
                "\nport = 29536\n", f"\nport = {port}\n"
            )
        )
        wire = _rig_run(wire_cfg, "--json")
    finally:
        _out, err = stop_rig(emulator, timeout=20)
    assert emulator.returncode == 0, err
    here_cfg = tmp_path / "here.toml"
    here_cfg.write_text(text.replace('output = "runs"', f"output = {json.dumps(str(here_dir))}"))
    here = _rig_run(here_cfg, "--emulate", "--json")
    assert wire["safe_stop_reason"] is None and wire["stop_confirmed"] is True
    assert wire["cycles"] == here["cycles"] == 500
    _, a = read_samples(str(wire["run_dir"]))
    _, b = read_samples(str(here["run_dir"]))
    names = [n for n in a if n.endswith((".velocity", ".position"))]
    assert len({n.split(".")[0] for n in names}) == 2  # both axes recorded
    for column in names:
        assert np.max(np.abs(a[column])) > 0.1, column  # each axis moved
    for column in ("measurement", "reference", "command", *names):
        assert np.max(np.abs(a[column] - b[column])) < 1e-9, column
