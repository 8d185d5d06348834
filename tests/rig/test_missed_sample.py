"""A cycle without a new sample does not step the law on stale feedback, and the watchdog's
real-time floor is in seconds.

Lock-step on the emulated dc-servo drive: its TPDOs stop at 0.2 s (fault injection); until
the watchdog (20 periods) stops the run, ``missed_sample = "hold"`` sends the last command
again each cycle (the same RPDO: the drive holds it, and its RPDO deadline of 5 periods sees
the host alive) and "zero" sends 0 V.
"""

from __future__ import annotations

import dataclasses
import pathlib
import types

import can
import numpy as np
import pytest

from rig.config import AxisLimits, load_config, replace_axis
from rig.host.rundir import read_samples
from rig.host.safety import AxisGuard
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
STALL = 0.2  #: [s]


def _run(tmp_path: pathlib.Path, missed: str):  # type: ignore[no-untyped-def]
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=0.5, missed_sample=missed),
        faults=dataclasses.replace(cfg.faults, tpdo_stall_at=STALL),
    )
    cfg = replace_axis(cfg, "motor", limits={"watchdog_periods": 20})
    with Session(cfg, emulate=True) as session:
        session.start()
        summary = session.run()
    _, samples = read_samples(summary["run_dir"])
    trace = list(can.ASCReader(str(pathlib.Path(summary["run_dir"]) / "trace.asc")))
    return summary, samples, trace


@pytest.mark.parametrize("missed", ["hold", "zero"])
def test_no_law_step_on_stale_feedback(tmp_path: pathlib.Path, missed: str) -> None:
    summary, samples, trace = _run(tmp_path, missed)
    assert "no TPDO for 20 periods" in summary["safe_stop_reason"]
    assert summary["held_cycles"] >= 19
    t, u = samples["t"], samples["command"]
    stale = t > STALL + 0.001  # the first cycle after the stall still reads the last TPDO
    before = u[~stale][-1]
    expected = before if missed == "hold" else 0.0
    assert np.all(u[stale] == expected), u[stale]
    # the host's RPDOs (0x201) in the stall window, before the stop's neutral command (the last
    # with enable operation, 0x000F: the stop's own RPDOs carry the quick stop)
    start = trace[0].timestamp
    window = [
        m for m in trace if not m.is_rx and m.arbitration_id == 0x201 and STALL + 0.002 < m.timestamp - start
    ]
    sent_in_stall = [m for m in window if m.data[:2] == b"\x0f\x00"][:-1]
    if missed == "hold":  # the held command, each cycle until the watchdog
        held = [m for m in trace if not m.is_rx and m.arbitration_id == 0x201 and m not in window][-1]
        assert len(sent_in_stall) >= 10 and all(m.data == held.data for m in sent_in_stall)
    else:  # 0 V each cycle until the watchdog
        assert len(sent_in_stall) >= 10 and all(not any(m.data[2:]) for m in sent_in_stall)


def test_the_real_time_watchdog_is_at_least_its_time() -> None:
    axis = types.SimpleNamespace(name="m", where="node 1", measures=frozenset({"velocity"}))
    limits = AxisLimits(watchdog_periods=3, watchdog=0.1)
    assert AxisGuard(axis, limits, 0.001, realtime=True).watchdog_periods == 100  # type: ignore[arg-type]
    assert AxisGuard(axis, limits, 0.001).watchdog_periods == 3  # type: ignore[arg-type]  # lock-step
    many = AxisLimits(watchdog_periods=500, watchdog=0.1)
    assert AxisGuard(axis, many, 0.001, realtime=True).watchdog_periods == 500  # type: ignore[arg-type]
