"""The whole chain across real processes and sockets: ``rig emulate`` in its own process behind
socketcand, the host on python-can's socketcand client, lock-step (SYNC, then every TPDO awaited)."""

from __future__ import annotations

import dataclasses
import pathlib
import re
from typing import Any

import numpy as np

from rig.config import BusConfig, RigConfig, replace_axis
from rig.emulator.spawn import spawn_rig, stop_rig
from rig.host.rundir import read_samples
from rig.host.session import Session
from rig.papers.demo import demo_config


def _run(cfg: RigConfig, *, emulate: bool) -> dict[str, Any]:
    with Session(cfg, emulate=emulate, duration=0.2) as session:
        session.start()
        return session.run()


def test_lockstep_over_socketcand_equals_the_in_process_run(tmp_path: pathlib.Path) -> None:
    cfg = demo_config(str(tmp_path))
    params = [arg for k, v in cfg.emulator.params.items() for arg in ("--param", f"{k}={v}")]
    proc, line = spawn_rig(
        "emulate",
        "--preset",
        "dc-servo",
        "--time",
        "lockstep",
        "--port",
        "0",
        *params,
        stderr=True,
    )
    try:
        match = re.search(r"socketcand://127\.0\.0\.1:(\d+)", line)
        assert match, line
        wire_cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, period=0.4e-3),
            bus=BusConfig(interface="socketcand", channel="can0", port=int(match.group(1))),
        )
        # the example's 3-period watchdog (1.2 ms) counts SYNCs; the wait for each answer over
        # the socket is the watchdog in seconds (two processes share two cores: 2 s here)
        wire_cfg = replace_axis(wire_cfg, "motor", limits={"watchdog_periods": 3, "watchdog": 2.0})
        wire = _run(wire_cfg, emulate=False)
    finally:
        _, err = stop_rig(proc, timeout=20)
    assert proc.returncode == 0, err
    here = _run(cfg, emulate=True)
    assert wire["safe_stop_reason"] is None and wire["cycles"] == here["cycles"] == 500
    _, a = read_samples(wire["run_dir"])
    _, b = read_samples(here["run_dir"])
    assert np.max(np.abs(a["measurement"])) > 0.0  # it did move
    for column in ("measurement", "command", "motor.velocity"):
        assert np.max(np.abs(a[column] - b[column])) < 1e-9, column
