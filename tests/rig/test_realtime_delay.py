"""One delay structure, shown by the order of the frames, not by a latency: in real time, the
host's command of cycle k answers the sample of its own SYNC k, as in lock-step.

The section VII.B servo (``examples/dc_servo_position_rt.toml``) runs against ``rig emulate`` in
its own process over socketcand, in real time and in lock-step (the emulator's ``--time``). The
host's CAN trace (``trace.asc``: every frame it sent, and every frame it received, traced before
canopen's listener wakes the loop) gives the order of events. CiA 402's cyclic synchronous
structure: the host sends SYNC k, the drive samples at it and answers with its TPDO, the host
waits for that answer, runs the law and sends its RPDO, which (``sync_rpdo = true``) acts at
SYNC k+1. A node answers the SYNCs in order, so before the RPDO of a cycle that waited for its
answer, the host has received as many TPDOs as it has sent SYNCs. Before the host waited, the
RPDO followed SYNC k before its answer came: every command answered the sample of SYNC k-1, a
period more delay than in lock-step (and than the tests proved).

What the load changes is only which cycles were late (their answers missed the budget; the row
says so, and the cycle used what it had). After two late cycles in a row, the host carries
over at most one owed answer (``rig.host.pacing._Answers``), so the next cycle may read a sample
a period old without being late: cycles after two late ones are left out. The check holds for
every other cycle whatever the machine's load; no latency, rms or period figure is asserted
(those are ``rig bench stops``'s).
"""

from __future__ import annotations

import dataclasses
import pathlib

import can
import numpy as np
import pytest

from rig.config import BusConfig, load_config
from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.host.rundir import read_samples
from rig.host.session import Session

pytestmark = pytest.mark.timing  #: real time across processes

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position_rt.toml"
PERIOD = 0.002  #: [s] a budget of most of it: late cycles stay rare on a loaded machine
BUDGET = 0.0018  #: [s]
CYCLES = 300
SYNC, TPDO, RPDO = 0x080, 0x181, 0x201  #: node 1's


def _run(out: pathlib.Path, time: str) -> dict[str, object]:
    """The example run ``CYCLES`` cycles in ``time`` ("realtime" or "lockstep") against
    ``rig emulate`` in its own process: the summary."""
    proc, port = spawn_emulator("--preset", "dc-servo", "--time", time, "--param", f"period={PERIOD}")
    try:
        cfg = load_config(EXAMPLE)
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(
                cfg.run, time=time, period=PERIOD, answer_budget=BUDGET, output=str(out), trace="asc"
            ),
            bus=BusConfig(interface="socketcand", channel="can0", port=port),
        )
        with Session(cfg, emulate=False, duration=CYCLES * PERIOD) as session:
            session.start()
            return session.run()
    finally:
        stop_rig(proc, timeout=20)


def _answered(run_dir: str) -> tuple[list[bool], list[bool]]:
    """For each cycle (row): whether its RPDO followed the answers to every SYNC sent before it
    (TPDOs received >= SYNCs sent, from the trace's order), and whether the row was late."""
    with can.ASCReader(str(pathlib.Path(run_dir) / "trace.asc")) as reader:
        frames = [(m.arbitration_id, m.is_rx) for m in reader if not m.is_error_frame]
    syncs = answers = 0
    answered = []
    for cob, rx in frames:
        if cob == SYNC and not rx:
            syncs += 1
        elif cob == TPDO and rx:
            answers += 1
        elif cob == RPDO and not rx:
            answered.append(answers >= syncs)
    _, rows = read_samples(run_dir)
    late = [bool(x) for x in rows["late"]]
    assert len(answered) >= len(late) > 0, (len(answered), len(late))  # (the stop may send more)
    return answered[: len(late)], late


def _checked(late: list[bool]) -> np.ndarray:
    """The cycles the structure is checked on: not late, and not after two late ones in a row."""
    late_ = np.array(late)
    before = np.concatenate(([False, False], late_[:-2] & late_[1:-1]))[: len(late_)]
    return np.flatnonzero(~late_ & ~before)


@pytest.mark.parametrize("time", ["lockstep", "realtime"])
def test_each_command_answers_the_sample_of_its_own_sync(tmp_path: pathlib.Path, time: str) -> None:
    summary = _run(tmp_path, time)
    answered, late = _answered(str(summary["run_dir"]))
    checked = _checked(late)
    assert len(checked) > 0, summary
    wrong = [int(k) for k in checked if not answered[k]]
    assert not wrong, f"cycles {wrong[:10]} sent their command before the answer to their SYNC ({summary})"


def test_late_cycles_and_those_after_two_late_ones_are_not_checked() -> None:
    assert _checked([False, True, True, False, False]).tolist() == [0, 4]
    assert _checked([True, False, True, False]).tolist() == [1, 3]
