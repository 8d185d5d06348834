"""One delay structure: the section VII.B position servo (``examples/dc_servo_position.toml``)
run in real time against ``rig emulate`` in its own process over socketcand follows the error
trajectory of the same servo run in lock-step: the same to 1e-9 rad over its first cycles (up to
50, and before any late or skipped one), and within 10 % rms over the run.

Both runs have the structure of the CiA 402 cyclic synchronous modes: the host sends SYNC, the
drive samples at it, the host waits for the TPDOs answering it (in real time up to the budget,
half the period) and sends its RPDO; a synchronous RPDO (``sync_rpdo = true``) acts at the next
SYNC. Before the host waited for the answers, a real-time command answered the sample of the
SYNC before (and the drive's period was not locked to SYNC): 19-51 times the lock-step rms
error. The load step is left out (its time counts from the drive's enable, which lies a
different time before the first cycle in the two modes); the run covers the 1 s move.

The period is 1 ms, not the paper's 0.4 ms: a cycle of the example carries SYNC, two TPDOs and
an RPDO, 430 bit times with worst-case stuffing, more than 0.4 ms of a 1 Mbit/s bus, and the
emulator's bus carries no more than its bit rate (``plant_emulator.bus_time``): at 0.4 ms the
frames queue and most cycles are late, which shows the bus, not the host. After a late or
skipped cycle a sliding-mode servo settles on an equally good trajectory, not the same one:
hence the exact comparison before the first, and the rms over the run. (A synchronous RPDO
that reaches the drive after the next SYNC acts a period later, unseen by the host: on a loaded
machine it can happen in a cycle that was not late.)
"""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Any

import numpy as np
import pytest

from rig.config import BusConfig, RigConfig, load_config, replace_axis
from rig.host.rundir import read_samples
from rig.host.session import Session
from rig.process import spawn_emulator, stop_rig

pytestmark = pytest.mark.timing  #: real time across processes: wall-clock bound

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
PERIOD = 0.001  #: [s]
DURATION = 1.2  #: [s] the 1 s move and its settling


def _config(out: pathlib.Path) -> RigConfig:
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, period=PERIOD, output=str(out)),
        emulator=dataclasses.replace(cfg.emulator, params={"period": PERIOD}),
    )
    return replace_axis(cfg, "motor", sync_rpdo=True)


def _errors(summary: dict[str, Any]) -> tuple[dict[int, float], int]:
    """{cycle index: reference - measurement} of a run's rows, and the first cycle that was late
    or came after skipped ones (the number of rows if none)."""
    _, rows = read_samples(summary["run_dir"])
    k = np.rint(rows["t"] / PERIOD).astype(int)
    disturbed = np.flatnonzero((rows["late"] > 0) | (np.diff(k, prepend=-1) != 1))
    first = int(k[disturbed[0]]) if disturbed.size else len(k)
    return dict(zip(k.tolist(), (rows["reference"] - rows["measurement"]).tolist())), first


def test_the_realtime_error_trajectory_is_the_lockstep_one(tmp_path: pathlib.Path) -> None:
    cfg = _config(tmp_path)
    with Session(cfg, emulate=True, duration=DURATION) as session:
        session.start()
        lockstep = session.run()
    proc, port = spawn_emulator("--preset", "dc-servo", "--param", f"period={PERIOD}")
    try:
        rt_cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, time="realtime"),
            bus=BusConfig(interface="socketcand", channel="can0", port=port),
        )
        with Session(rt_cfg, emulate=False, duration=DURATION) as session:
            session.start()
            realtime = session.run()
    finally:
        _, err = stop_rig(proc, timeout=20)
    assert proc.returncode == 0, err[-2000:]
    assert lockstep["safe_stop_reason"] is None and realtime["safe_stop_reason"] is None, realtime
    (a, first), (b, _) = _errors(realtime), _errors(lockstep)
    summary = {k: realtime[k] for k in ("overruns", "late_cycles", "held_cycles", "realtime", "timing")}
    # the same to 1e-9 from the start: a command answers the sample of its own SYNC in both modes
    # (a period more delay in one of them shows from the second cycle on)
    undisturbed = [k for k in range(min(first, 50)) if k in b]
    assert len(undisturbed) >= 10, summary  # (a loaded machine may disturb the first cycles)
    assert max(abs(a[k] - b[k]) for k in undisturbed) < 1e-9, summary
    common = sorted(set(a) & set(b))
    assert len(common) >= 0.99 * len(b), summary
    rms_rt = float(np.sqrt(np.mean([a[k] ** 2 for k in common])))
    rms_ls = float(np.sqrt(np.mean([b[k] ** 2 for k in common])))
    assert abs(rms_rt - rms_ls) <= 0.1 * rms_ls, (rms_rt, rms_ls, first, summary)
