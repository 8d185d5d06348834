"""A run on a real bus loads no ``plant_emulator`` module (issue 37 item 2).

What the host and the emulator share (time profiles, CAN bit timing, parameter types) lives below
both, in ``drivers``, and the emulated world is imported only where a run emulates. Checked in a
fresh interpreter (this one has the emulator loaded by other tests): a configuration without an
``[emulator]`` table is loaded, ``rig.host.session`` imported, a Session built on socketcan
(opening the bus, refused on a machine without that interface) and then a whole lock-step run on
socketcand against ``rig emulate`` in a third process; after each, the ``plant_emulator`` modules
in ``sys.modules`` are listed.
"""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

from rig.emulator.spawn import spawn_emulator, stop_rig

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: run in a fresh interpreter: argv[1] the socketcan file, argv[2] the socketcand one
PROBE = """
import json, sys

def emulator():
    return sorted(m for m in sys.modules if m.split(".")[0] == "plant_emulator")

seen = {}
from rig.config import load_config
from rig.host.session import Session
from drivers.errors import RigError
seen["import"] = emulator()
try:
    Session(load_config(sys.argv[1]), emulate=False).close()
    seen["socketcan_opened"] = True
except RigError as exc:
    seen["socketcan_opened"] = str(exc)
seen["socketcan"] = emulator()
with Session(load_config(sys.argv[2]), emulate=False) as session:
    session.start()
    summary = session.run()
seen["run"] = {k: summary[k] for k in ("cycles", "safe_stop_reason")}
seen["socketcand"] = emulator()
print(json.dumps(seen))
"""


def _config(tmp_path: pathlib.Path, name: str, bus: str) -> pathlib.Path:
    """The DC servo example as a file for a real bus: no ``[emulator]``, ``[run] period`` given."""
    text = (ROOT / "examples" / "dc_servo_position.toml").read_text()
    head, _, rest = text.partition("[emulator]")
    _, _, axes = rest.partition("[[axis]]")
    head = head.replace("duration = 3.0", "duration = 0.02\nperiod = 0.4e-3")
    head = head.replace('output = "runs"', f"output = {str(tmp_path / 'runs')!r}")
    bus_table = head[head.index("[bus]") :]
    head = head.replace(bus_table, bus)
    # the answers' wait over the socket (two processes on two loaded cores): as the other
    # cross-process runs (tests/rig/test_run_across_processes.py)
    axes = axes.replace("watchdog_periods = 3", "watchdog_periods = 3\nwatchdog = 2.0")
    path = tmp_path / f"{name}.toml"
    path.write_text(f"{head}\n[[axis]]{axes}")
    return path


def test_a_run_on_a_real_bus_imports_no_emulator_module(tmp_path: pathlib.Path) -> None:
    can = _config(tmp_path, "socketcan", '[bus]\ninterface = "socketcan"\nchannel = "rig-no-such-can"\n\n')
    proc, port = spawn_emulator("--preset", "dc-servo", "--time", "lockstep")
    try:
        cand = _config(
            tmp_path,
            "socketcand",
            f'[bus]\ninterface = "socketcand"\nchannel = "can0"\nhost = "127.0.0.1"\nport = {port}\n\n',
        )
        done = subprocess.run(
            [sys.executable, "-c", PROBE, str(can), str(cand)],
            check=False,
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
        )
    finally:
        stop_rig(proc, timeout=20)
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert "rig-no-such-can" in seen["socketcan_opened"]  # it got as far as opening the bus
    assert seen["run"] == {"cycles": 50, "safe_stop_reason": None}  # a whole run on the wire
    for step in ("import", "socketcan", "socketcand"):
        assert seen[step] == [], f"{step}: {seen[step]}"
