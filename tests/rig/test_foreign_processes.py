"""The first day across processes: the independent fake device (``tests/drivers/fake_device.py``)
in a process of its own behind a socketcand rawmode server of its own
(``tests/drivers/fake_socketcand.py``, written without drive-rig's code), and ``rig drive`` and
``rig run`` in other processes connecting to it with python-can's socketcand client, as the
README's "Pointing it at real hardware" runs them. The device's log is read at its end."""

from __future__ import annotations

import json
import pathlib
import signal
import subprocess
import sys
from collections.abc import Iterator
from typing import Any

import pytest

from tests.drivers.fake_device import Dictionary

ROOT = pathlib.Path(__file__).resolve().parents[2]

CONFIG = """[run]
duration = 0.2
period = 0.01
time = "lockstep"
output = "{out}"

[bus]
interface = "socketcand"
channel = "can0"
host = "127.0.0.1"
port = {port}

[[axis]]
name = "motor"
kind = "cia402"
node_id = 1
mode = "csp"
eds = "{eds}"

[axis.limits]
command = 20.0
speed = 300.0
current = 30.0

[controller]
kind = "position-reference"
reads = ["motor"]
commands = ["motor"]

[reference]
kind = "smooth-move"
distance = 1.0
duration = 0.1
"""


class Served:
    """``name`` served by the fake in its own process; ``log()`` ends it and gives its log."""

    def __init__(self, name: str, folder: pathlib.Path) -> None:
        self.dictionary = Dictionary.load(name)
        self.eds = str(self.dictionary.write_eds(folder))
        self._log = folder / "device-log.json"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tests.drivers.fake_socketcand", name, "--log", str(self._log)],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdout is not None
        self.port = int(self.proc.stdout.readline().split()[1])

    def rig(self, *argv: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "rig.cli", *argv], capture_output=True, text=True, timeout=60, check=False
        )

    def bus(self) -> list[str]:
        return [
            "--interface",
            "socketcand",
            "--channel",
            "can0",
            "--host",
            "127.0.0.1",
            "--port",
            str(self.port),
        ]

    def log(self) -> dict[str, Any]:
        self.proc.send_signal(signal.SIGTERM)
        _out, err = self.proc.communicate(timeout=20)
        assert self.proc.returncode == 0, err
        return dict(json.loads(self._log.read_text())["1"])


@pytest.fixture
def served(request: pytest.FixtureRequest, tmp_path: pathlib.Path) -> Iterator[Served]:
    s = Served(request.param, tmp_path)
    yield s
    if s.proc.returncode is None:
        s.proc.kill()
        s.proc.communicate(timeout=10)


@pytest.mark.parametrize("served", ["elmo-gold"], indirect=True)
def test_status_and_a_csp_run_across_processes_write_only_what_the_drive_declares(
    served: Served, tmp_path: pathlib.Path
) -> None:
    """A drive whose PDO parameters change only in PRE-OPERATIONAL with bit 31 set first:
    ``rig drive status`` writes nothing; ``rig run`` in CSP writes no manufacturer object, no
    entry its EDS declares read-only, and nothing the drive refused."""
    status = served.rig("drive", *served.bus(), "--eds", served.eds, "--json", "status")
    assert status.returncode == 0, status.stderr
    assert json.loads(status.stdout)["identity"]["vendor"] == "0x0000009A"
    cfg = tmp_path / "rig.toml"
    cfg.write_text(CONFIG.format(out=tmp_path / "runs", port=served.port, eds=served.eds))
    run = served.rig("run", "--config", str(cfg), "--json")
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["safe_stop_reason"] is None
    log = served.log()
    entries = served.dictionary.entries
    written = [(i, s) for i, s, _v, _a in log["downloads"]] + [(i, s) for i, s, _v in log["rpdo_writes"]]
    assert not [w for w in written if 0x2000 <= w[0] < 0x6000]
    assert not [w for w in written if w in entries and entries[w].access in ("ro", "const")]
    assert [d for d in log["downloads"] if d[3] is not None] == []
    assert log["rpdos"] and log["state"] == "SWITCH ON DISABLED"
