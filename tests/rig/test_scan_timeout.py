"""``rig scan --sdo-timeout S`` across processes: a drive whose SDO answers are slow is read
whole when the scan is told to wait for them."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

from plant_emulator.device_profile import zoo
from rig.emulator.spawn import spawn_emulator, stop_rig


def test_rig_scan_waits_as_long_as_it_is_told_for_each_sdo_answer(tmp_path: pathlib.Path) -> None:
    """``rig scan --sdo-timeout S``: a drive whose SDO answers take 0.3 s (its profile's
    ``[timing] sdo_response``, served by ``rig emulate --profile`` in its own process) is found
    but not read within the default 0.1 s, and read whole with ``--sdo-timeout 2``."""
    source = zoo()["epos4"]
    text = source.read_text().replace("sdo_response = 0.0005", "sdo_response = 0.3")
    text = text.replace('eds = "epos4.eds"', f'eds = "{source.with_suffix(".eds")}"')
    profile = tmp_path / "slow.toml"
    profile.write_text(text)
    proc, port = spawn_emulator("--profile", str(profile))
    try:
        rows = {}
        for timeout in ("0.1", "2"):
            out = subprocess.run(
                [sys.executable, "-m", "rig.cli", "scan", "--interface", "socketcand", "--channel", "can0",
                 "--port", str(port), "--listen", "0.8", "--sdo-timeout", timeout, "--json"],
                capture_output=True, text=True, timeout=120, check=True,
            )  # fmt: skip
            (rows[timeout],) = json.loads(out.stdout)
    finally:
        stop_rig(proc, timeout=20)
    assert rows["0.1"]["errors"] == ["0x1000:00: no SDO answer within 0.1 s"], rows["0.1"]
    assert rows["2"]["errors"] == [] and rows["2"]["vendor_id"] == "0x000000FB", rows["2"]
