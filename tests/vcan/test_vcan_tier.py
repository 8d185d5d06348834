"""The real SocketCAN code path: host on ``socketcan``/vcan0, emulator in its own process.

Run with ``python -m pytest -m vcan tests/vcan`` where vcan0 exists (or through
``../shared/tools/run-in-vcan-vm.sh``); skipped with the reason elsewhere.
"""

from __future__ import annotations

import dataclasses
import json
import pathlib
from typing import Any

import canopen
import numpy as np
import pytest

from drivers.bus import open_bus
from drivers.cia402 import Cia402Axis
from rig.cli import main
from rig.config import BusConfig, RigConfig, replace_axis
from rig.host.session import Session
from rig.papers.demo import demo_config
from tests.vcan.conftest import lockstep_servo

pytestmark = pytest.mark.vcan


def test_driver_contract_over_vcan(start_emulator) -> None:  # type: ignore[no-untyped-def]
    start_emulator("--preset", "dc-servo")
    network = canopen.Network(open_bus("socketcan", "vcan0"))
    network.connect()
    try:
        with Cia402Axis("drive", network, 1, mode="csv") as drive:
            drive.setup()
            assert drive.units.counts_per_rad == pytest.approx(4096 / (2 * np.pi))
            drive.enable(timeout=10.0)
            assert drive.read_power_state().value == "OPERATION ENABLED"
            drive.disable()
            assert drive.read_power_state().value == "SWITCH ON DISABLED"
    finally:
        network.disconnect()


def test_scan_over_vcan(start_emulator, capsys: pytest.CaptureFixture[str]) -> None:  # type: ignore[no-untyped-def]
    start_emulator("--preset", "dc-servo")
    assert main(["scan", "--interface", "socketcan", "--channel", "vcan0", "--listen", "1.5", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["node_id"], r["profile"]) for r in rows] == [(1, "CiA 402 drive"), (2, "CiA 406 encoder")]


def _run(cfg: RigConfig, *, emulate: bool, duration: float) -> dict[str, Any]:
    with Session(cfg, emulate=emulate, duration=duration) as session:
        session.start()
        return session.run()


def _samples(run_dir: str) -> np.ndarray:
    return np.genfromtxt(pathlib.Path(run_dir) / "samples.csv", delimiter=",", names=True)


def test_lockstep_servo_over_vcan_equals_the_in_process_run(start_emulator, tmp_path: pathlib.Path) -> None:  # type: ignore[no-untyped-def]
    cfg, wire_cfg = lockstep_servo(start_emulator, str(tmp_path))
    wire = _run(wire_cfg, emulate=False, duration=0.2)
    here = _run(cfg, emulate=True, duration=0.2)
    assert wire["safe_stop_reason"] is None and wire["cycles"] == here["cycles"] == 500
    a, b = _samples(wire["run_dir"]), _samples(here["run_dir"])
    assert np.max(np.abs(a["measurement"] - b["measurement"])) < 1e-9
    assert np.max(np.abs(a["command"] - b["command"])) < 1e-9
    assert np.max(np.abs(a["measurement"])) > 0.0  # it did move


def test_realtime_1khz_with_kernel_sync(start_emulator, tmp_path: pathlib.Path) -> None:  # type: ignore[no-untyped-def]
    """SYNC from the kernel's broadcast manager at 1 kHz; the figures are printed, not asserted.

    In the throw-away VM (emulated CPU, one vCPU for both processes) the host answers about one
    SYNC in seven: the loop skips the periods it missed and counts them as overruns, so the run
    ends after 2 s of bus time (it once hung 120 s counting 1 s waits as single periods)."""
    start_emulator("--preset", "dc-servo", "--param", "period=0.001")
    cfg = demo_config(str(tmp_path))
    rt = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, time="realtime", period=0.001),
        bus=BusConfig(interface="socketcan", channel="vcan0"),
        reference=dataclasses.replace(cfg.reference, kind="constant", value=0.0),
    )
    rt = replace_axis(rt, "motor", enable_timeout=10.0, limits={"watchdog_periods": 1000})
    summary = _run(rt, emulate=False, duration=2.0)
    timing = summary["timing"]
    print(
        f"\nvcan 1 kHz, kernel SYNC: cycles {summary['cycles']}, overruns {summary['overruns']}, "
        f"period error median {timing.get('period_error_median_us', float('nan')):.1f} us, "
        f"p99 {timing.get('period_error_p99_us', float('nan')):.1f} us, "
        f"max {timing.get('period_error_max_us', float('nan')):.1f} us, stop: {summary['safe_stop_reason']}"
    )
    assert summary["cycles"] > 0
