"""A drive fresh from the box given its node-ID across real processes: ``rig emulate --device epos4
--node 255`` (no node-ID: it answers LSS only) behind its socketcand server, and ``rig scan``,
``rig lss`` and ``rig drive`` as processes of their own over the socket, as on a bus: the scan finds
no node, ``rig lss scan`` finds the drive's address, ``rig lss --select ... node-id 5 --store``
hears it boot as node 5, and then node 5 is scanned, read and stored by ``rig drive``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from plant_emulator.device_profile import device_profile
from rig.emulator.spawn import spawn_emulator, stop_rig

pytestmark = pytest.mark.timing  #: real processes on a real clock (LSS answers awaited 0.5 s)

EPOS4 = "0x000000FB:0x65520000:0x00010000:0x00000001"


def _rig(port: int, *argv: str) -> subprocess.CompletedProcess[str]:
    bus = ["--interface", "socketcand", "--channel", "can0", "--host", "127.0.0.1", "--port", str(port)]
    return subprocess.run(
        [sys.executable, "-m", "rig.cli", argv[0], *bus, *argv[1:]],
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )


def _json(port: int, *argv: str) -> object:
    proc = _rig(port, *argv)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_a_fresh_drive_gets_its_node_id_over_the_bus_and_is_commissioned_as_that_node() -> None:
    eds = str(device_profile("epos4").eds)
    emulator, port = spawn_emulator("--device", "epos4", "--node", "255")
    try:
        assert _json(port, "scan", "--json") == []  # no node answers NMT or SDO
        found = _json(port, "lss", "--json", "scan")
        assert found == {
            "unconfigured": 1,
            "found": {
                "vendor": "0x000000FB",
                "product": "0x65520000",
                "revision": "0x00010000",
                "serial": "0x00000001",
            },
            "node_id": 255,
            "select": EPOS4,
        }
        out = _json(port, "lss", "--json", "--select", EPOS4, "node-id", "5", "--store")
        assert out["node_id_was"] == 255 and out["node_id"] == 5 and out["booted"] is True  # type: ignore[index]
        assert [row["node_id"] for row in _json(port, "scan", "--json")] == [5]  # type: ignore[attr-defined]
        status = _json(port, "drive", "--node", "5", "--eds", eds, "--json", "status")
        assert status["identity"]["serial"] == "0x00000001"  # type: ignore[index]
        stored = _rig(port, "drive", "--node", "5", "--eds", eds, "store", "--yes")
        assert (
            stored.returncode == 0 and "node 5's parameters are in its non-volatile memory" in stored.stdout
        )
        again = _json(port, "lss", "--json", "scan")
        assert again["unconfigured"] == 0  # type: ignore[index]
    finally:
        _, err = stop_rig(emulator)
    assert emulator.returncode == 0, err[-2000:]
