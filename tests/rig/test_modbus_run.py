"""The Modbus inverter under ``rig run``'s own path: TCP, and RTU over a pseudo-terminal pair; lock-step
and real time, with the inverter's communication-loss trip on (its default)."""

from __future__ import annotations

import dataclasses
import gc
import time
from pathlib import Path

import numpy as np
import pytest

from drivers.errors import ConfigError
from drivers.files import read_toml
from rig.config import load_config, replace_axis, rig_config
from rig.host.rundir import read_samples
from rig.host.session import Session

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "modbus_inverter_speed.toml"


@pytest.mark.parametrize(
    ("line", "clock"),
    [("tcp", "lockstep"), ("rtu", "lockstep"), pytest.param("tcp", "realtime", marks=pytest.mark.timing)],
)
def test_the_inverter_reaches_its_speed_and_ends_stopped(line: str, clock: str, tmp_path: Path) -> None:
    """The run lasts 1 s, twice the inverter's communication-loss time: the host's poll every
    cycle keeps it running, in lock-step (one period of its clock per cycle) and in real time."""
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), time=clock))
    if line == "rtu":  # with --emulate, the serial line is a pty pair with the inverter at its far end
        cfg = replace_axis(cfg, "inverter", host="", serial="/dev/ttyS-emulated", baudrate=115200)
    with Session(cfg, emulate=True, duration=1.0) as session:
        session.start()
        summary = session.run()
        model, _ = session.transport.emulation.inverters["inverter"]  # type: ignore[union-attr]
        assert not model.running  # the run ended with the inverter stopped
    # real time: a cycle the loaded machine skipped is counted under overruns, not run
    assert summary["safe_stop_reason"] is None and summary["cycles"] + summary["overruns"] == 100
    assert model.fault == 0  # no communication-loss trip
    _, columns = read_samples(summary["run_dir"])
    speed = columns["inverter.velocity"]
    assert speed[-1] == pytest.approx(50.0, abs=0.5)  # 100 rad/s^2 ramp from 0.1 s: at 50 by 0.6 s
    assert np.all(columns["inverter.command"][columns["t"] >= 0.1] == 50.0)
    assert summary["axes"]["inverter"]["max_abs_current"] > 0.0


def test_a_period_the_inverter_would_trip_in_is_refused(tmp_path: Path) -> None:
    """Refused when the file is loaded; with a longer comm_loss_timeout, the run goes."""
    doc = read_toml(EXAMPLE)
    doc["run"].update(output=str(tmp_path), period=0.5)
    with pytest.raises(ConfigError, match=r"period 0.5 s is not shorter than .* comm_loss_timeout 0.5 s"):
        rig_config(doc, "FILE")
    doc.setdefault("emulator", {})["inverter"] = {"comm_loss_timeout": 2.0}
    slow = rig_config(doc, "FILE")
    with Session(slow, emulate=True, duration=1.0) as session:
        session.start()
        assert session.run()["safe_stop_reason"] is None


@pytest.mark.timing
def test_a_large_heap_does_not_trip_the_inverter_in_real_time(tmp_path: Path) -> None:
    """The host's full garbage collection before its first cycle comes before the enable: on
    a heap that takes longer to collect than the inverter's communication-loss time, the run
    still polls in time (it tripped with the collection between enable and the first poll)."""
    timeout = 0.2  # [s] the inverter's, so that a heap of a few million objects is enough
    cfg = load_config(EXAMPLE)
    emulator = dataclasses.replace(cfg.emulator, inverter={"comm_loss_timeout": timeout})
    run = dataclasses.replace(cfg.run, output=str(tmp_path), time="realtime")
    cfg = dataclasses.replace(cfg, run=run, emulator=emulator)
    heap: list[list[int]] = []
    while True:  # until a full collection takes 1.5 timeouts (the test's premise, checked)
        heap.extend([i] for i in range(500_000))
        start = time.perf_counter()
        gc.collect()
        if time.perf_counter() - start > 1.5 * timeout or len(heap) >= 10_000_000:
            break
    assert time.perf_counter() - start > 1.5 * timeout
    with Session(cfg, emulate=True, duration=0.5) as session:
        session.start()
        summary = session.run()
        model, _ = session.transport.emulation.inverters["inverter"]  # type: ignore[union-attr]
    assert summary["safe_stop_reason"] is None and model.fault == 0
    del heap
