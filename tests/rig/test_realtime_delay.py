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
says so, and the cycle used what it had). The host carries every owed answer over
(``rig.host.sync_answers.SyncAnswers``), so the check holds for every cycle not late, whatever the
machine's load, and after a stall of either process (SIGSTOP for ``STALL`` periods, three
times: the emulator answers the SYNCs it missed in a burst, which a cycle that took part of it
for its own answer, carrying one owed answer at most, acted on while not late). No latency, rms
or period figure is asserted (those are ``rig bench stops``'s).
"""

from __future__ import annotations

import dataclasses
import json
import os
import pathlib
import signal
import subprocess
import sys
import time as clock

import can
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
STALL = 10  #: [periods] each SIGSTOP lasts


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


def _wrong(answered: list[bool], late: list[bool]) -> list[int]:
    """The cycles not late whose command went before the answer to their own SYNC."""
    return [k for k, (a, x) in enumerate(zip(answered, late, strict=True)) if not x and not a]


@pytest.mark.parametrize("time", ["lockstep", "realtime"])
def test_each_command_answers_the_sample_of_its_own_sync(tmp_path: pathlib.Path, time: str) -> None:
    summary = _run(tmp_path, time)
    answered, late = _answered(str(summary["run_dir"]))
    assert not all(late), summary
    wrong = _wrong(answered, late)
    assert not wrong, f"cycles {wrong[:10]} sent their command before the answer to their SYNC ({summary})"


def _config(out: pathlib.Path, port: int) -> pathlib.Path:
    """The example for ``rig run`` against the emulator on ``port``: ``PERIOD``, its trace, the
    host's TPDO watchdog and the drive's RPDO deadline longer than a stall (the stall is the
    test's, not a fault to stop on)."""
    text = EXAMPLE.read_text()
    for old, new in (
        ("duration = 3.0 ", "duration = 1.5 "),
        (
            "period = 0.0004         # s, the paper's",
            f'period = {PERIOD}\ntrace = "asc"\nanswer_budget = {BUDGET}',
        ),
        ("period = 0.0004              # s", f"period = {PERIOD}"),
        ('output = "runs"', f'output = "{out}"'),
        ("port = 29536", f"port = {port}"),
        ("watchdog_periods = 3", f"watchdog_periods = {5 * STALL}"),
        ("sync_rpdo = true ", f"rpdo_deadline = {25 * STALL * PERIOD}\nsync_rpdo = true "),
    ):
        assert old in text, old
        text = text.replace(old, new, 1)
    path = out / "run.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("frozen", ["emulator", "host"])
def test_after_a_stall_of_either_process_no_cycle_on_time_acts_on_an_older_sample(
    tmp_path: pathlib.Path, frozen: str
) -> None:
    """``rig run`` and ``rig emulate`` in processes of their own; one of them SIGSTOPped for
    ``STALL`` periods three times during the cycles. Every cycle not late acted on the answer to
    its own SYNC; the stalls made cycles late (the emulator's) or overrun (the host's)."""
    emulator, port = spawn_emulator("--preset", "dc-servo", "--param", f"period={PERIOD}")
    host = None
    try:
        host = subprocess.Popen(
            [sys.executable, "-m", "rig.cli", "run", "--config", str(_config(tmp_path, port)), "--json"],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        deadline = clock.monotonic() + 60.0
        while not list(tmp_path.glob("*/started.json")):  # the cycles have begun
            assert host.poll() is None and clock.monotonic() < deadline, "rig run ended before its cycles"
            clock.sleep(0.01)
        victim = emulator if frozen == "emulator" else host
        for _ in range(3):
            clock.sleep(0.2)  # (when, not a decision)
            victim.send_signal(signal.SIGSTOP)
            clock.sleep(STALL * PERIOD)
            victim.send_signal(signal.SIGCONT)
        out, _ = host.communicate(timeout=60.0)
    finally:
        if host is not None and host.poll() is None:
            os.kill(host.pid, signal.SIGCONT)
            host.kill()
            host.communicate()
        emulator.send_signal(signal.SIGCONT)
        stop_rig(emulator, timeout=20)
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["safe_stop_reason"] is None, summary
    answered, late = _answered(str(summary["run_dir"]))
    assert sum(late) if frozen == "emulator" else summary["overruns"], summary  # the stalls were felt
    wrong = _wrong(answered, late)
    assert not wrong, f"cycles {wrong[:10]} acted on a sample older than their SYNC's, not late ({summary})"
