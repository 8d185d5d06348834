"""The host's SYNC and the answers to it (``rig.host.pacing.HostSync``), deterministically: a node
on the in-process bus answers each SYNC as the test says (its frames arrive within the SYNC's
send, so a budget of 0 s decides nothing by the clock). A cycle whose answers do not all come is
late; the answer it missed is owed, and the next frame on that COB-ID pays it, not the next SYNC;
the host loop counts late cycles in each row and the summary, and ``late_stop`` of them in a row
are a safe stop named as such."""

from __future__ import annotations

import dataclasses
import pathlib
import threading
import time
import types
from collections.abc import Iterator

import canopen
import numpy as np
import pytest

from drivers.cia402 import Cia402Axis
from drivers.cia406 import Cia406Axis
from plant_emulator.lockstep import LockstepBench, SyncHub, SyncNetwork, attach_network
from rig.config import load_config
from rig.host.cycle_clock import prime
from rig.host.pacing import HostSync, Pacing
from rig.host.rundir import read_samples
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
COBS = (0x181, 0x281)


NodeBus = tuple[HostSync, list[dict[int, int]], canopen.Network]


@pytest.fixture
def bus(node_bus: NodeBus) -> tuple[HostSync, list[dict[int, int]]]:
    """``node_bus`` without its node."""
    return node_bus[0], node_bus[1]


@pytest.fixture
def node_bus() -> Iterator[NodeBus]:
    """A ``HostSync`` (budget 0 s), the script of the node: per SYNC, {COB-ID: frames to send}
    (a COB-ID left out is not answered; missing SYNCs: one frame each), and the node's network."""
    hub = SyncHub()
    host, node = SyncNetwork(), canopen.Network()
    attach_network(host, hub.bus(queue=False, channel="host"))
    attach_network(node, hub.bus(queue=False, channel="node"))
    script: list[dict[int, int]] = []
    syncs = [0]

    def on_sync(can_id: int, data: bytearray, ts: float) -> None:
        n = syncs[0]
        syncs[0] += 1
        for cob, frames in (script[n] if n < len(script) else dict.fromkeys(COBS, 1)).items():
            for _ in range(frames):
                node.send_message(cob, b"\x00" * 8)

    node.subscribe(0x80, on_sync)
    axis = types.SimpleNamespace(tpdo_cob_ids=lambda: list(COBS), tpdos_not_awaited=list)
    pacing = HostSync(host, [axis], 0.0)  # type: ignore[list-item]
    yield pacing, script, node
    pacing.close()
    host.bus.shutdown()
    node.bus.shutdown()


def test_a_cycle_without_all_its_answers_is_late_and_owes_them(
    bus: tuple[HostSync, list[dict[int, int]]],
) -> None:
    pacing, script = bus
    both = dict.fromkeys(COBS, 1)
    script += [
        both,
        {0x181: 1},  # 0x281 misses SYNC 1: late
        {0x181: 1, 0x281: 2},  # SYNC 1's answer, then SYNC 2's: on time
        {0x181: 1},  # late again
        {0x181: 1, 0x281: 1},  # only the owed answer came: SYNC 4's is still to come
        {0x181: 1, 0x281: 2},  # SYNC 4's and 5's
        both,
    ]
    late = []
    for _ in script:
        pacing.tick()
        late.append(pacing.late)
    assert late == [False, True, False, True, True, False, False]


def test_a_stall_is_over_once_its_whole_burst_has_come(
    bus: tuple[HostSync, list[dict[int, int]]],
) -> None:
    """Five SYNCs unanswered, then the burst of their answers with the sixth's: the cycle of the
    burst is on time, and the next one with its own answer too. A SYNC never answered (a lost
    frame) leaves its answer owed: late ever after."""
    pacing, script = bus
    script += [{}] * 5 + [dict.fromkeys(COBS, 6), dict.fromkeys(COBS, 1), {}] + [dict.fromkeys(COBS, 1)] * 3
    late = []
    for _ in script:
        pacing.tick()
        late.append(pacing.late)
    assert late == [True] * 5 + [False, False] + [True] * 4


def test_a_cycle_with_part_of_a_stalls_burst_is_late(
    bus: tuple[HostSync, list[dict[int, int]]],
) -> None:
    """Five SYNCs unanswered; with the sixth, three answers of the six owed come, with the
    seventh the other four: the sixth cycle is late (it holds the third answer, a sample three
    periods old), the seventh on time with its own. Carrying one owed answer at most (a first
    version), the sixth was on time on that old sample."""
    pacing, script = bus
    script += [{}] * 5 + [dict.fromkeys(COBS, 3), dict.fromkeys(COBS, 4), dict.fromkeys(COBS, 1)]
    late = []
    for _ in script:
        pacing.tick()
        late.append(pacing.late)
    assert late == [True] * 5 + [True, False, False]


def test_the_last_cycle_s_owed_answers_are_awaited_before_the_stop(node_bus: NodeBus) -> None:
    """``settle`` (the loop's last look, ``HostLoop._last_look``): after a late last cycle it waits,
    up to the budget, for the answer still owed, so every frame the bus carried before it has been
    handed on to the watches; with nothing owed it returns at once, whatever the budget."""
    pacing, script, node = node_bus
    script += [{0x181: 1}]  # 0x281 misses the last SYNC: late, its answer owed
    pacing.tick()
    assert pacing.late and pacing.owes()
    heard: list[int] = []
    pacing.network.subscribe(0x201, lambda cob, data, ts: heard.append(cob))
    pacing.budget = 60.0  # a bound: the answer comes within ms

    def later() -> None:  # another master's RPDO, then the owed answer, after the tick
        time.sleep(0.05)
        node.send_message(0x201, bytes(6))
        node.send_message(0x281, bytes(8))

    sender = threading.Thread(target=later)
    began = time.monotonic()
    sender.start()
    pacing.settle()
    sender.join()
    assert not pacing.owes() and heard == [0x201]
    pacing.settle()  # nothing owed: at once, not after the 60 s budget
    assert time.monotonic() - began < 30.0


class LateAt(Pacing):
    """The emulated world's lock-step pacing, with the cycles (tick numbers) in ``late`` declared
    late, as a ``HostSync`` whose answers missed the budget declares them."""

    def __init__(self, inner: Pacing, late: set[int]) -> None:
        self.inner, self.ticks, self.at = inner, 0, late

    def tick(self) -> None:
        self.inner.tick()
        self.late = self.ticks in self.at
        self.ticks += 1

    def now(self) -> float:
        return self.inner.now()


def _run(tmp_path: pathlib.Path, late: set[int], late_stop: int) -> tuple[dict, dict]:  # type: ignore[type-arg]
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(
        cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=0.2, late_stop=late_stop)
    )
    with Session(cfg, emulate=True) as session:
        session.start()
        assert session.loop is not None
        session.loop.pacing = LateAt(session.loop.pacing, late)
        summary = session.run()
    _, samples = read_samples(summary["run_dir"])
    return summary, samples


def test_late_cycles_are_counted_in_the_rows_and_the_summary(tmp_path: pathlib.Path) -> None:
    late = {10, 11, 50, 51, 52, 400}
    summary, samples = _run(tmp_path, late, late_stop=4)
    assert summary["safe_stop_reason"] is None
    assert summary["late_cycles"] == len(late)
    assert set(np.flatnonzero(samples["late"])) == late


def test_late_cycles_in_a_row_are_a_safe_stop_named_as_such(tmp_path: pathlib.Path) -> None:
    summary, samples = _run(tmp_path, {20, 30, 31, 32}, late_stop=3)
    reason = summary["safe_stop_reason"]
    assert reason.startswith("3 late cycles in a row (cycles 30-32)"), reason
    assert "[run] answer_budget" in reason and "late_stop = 3" in reason
    assert summary["late_cycles"] == 4 and summary["cycles"] == 33
    assert summary["stop_confirmed"] is True
    assert samples["late"][-1] == 1.0


def test_owed_answers_are_known_until_the_burst_has_come(
    bus: tuple[HostSync, list[dict[int, int]]],
) -> None:
    """``owes()`` (the real-time prime goes on while it is true: cycle 0 does not begin behind a
    drive slow to start): true after SYNCs without their answers, false once all have come."""
    pacing, script = bus
    script += [{}, {}, dict.fromkeys(COBS, 2), dict.fromkeys(COBS, 2)]
    assert not pacing.owes()
    owes = []
    for _ in script:
        pacing.tick()
        owes.append(pacing.owes())
    assert owes == [True, True, True, False]


def test_answers_forgotten_are_not_awaited(
    bus: tuple[HostSync, list[dict[int, int]]], caplog: pytest.LogCaptureFixture
) -> None:
    """``forget_owed`` (the prime's end, answers still owed): the next cycle awaits only its own
    SYNC's answers, and the log names what was forgotten and why."""
    pacing, script = bus
    script += [{}, {}, {}, dict.fromkeys(COBS, 1)]
    late = []
    for _ in script[:3]:
        pacing.tick()
        late.append(pacing.late)
    with caplog.at_level("WARNING", logger="rig.host.pacing"):
        pacing.forget_owed("the test's reason")
    assert not pacing.owes()
    assert "(the test's reason): 3 on 0x181, 3 on 0x281" in caplog.text
    pacing.tick()
    late.append(pacing.late)
    assert late == [True, True, True, False]


def test_the_prime_forgets_what_is_still_owed_at_its_end(
    bus: tuple[HostSync, list[dict[int, int]]], caplog: pytest.LogCaptureFixture
) -> None:
    """The real-time prime (``rig.host.cycle_clock.prime``) sends SYNC until no answer is owed, at most 1 s
    here; a node that never answers on 0x281 during it leaves answers owed, which cycle 0 does
    not await (logged with the prime's reason): it is on time with its own SYNC's answers.
    Awaited, every cycle would be late, the late-cycle stop after ``late_stop``. (The 1 s is the
    prime's bound, reached whatever the machine's speed: it decides nothing.)"""
    pacing, script = bus
    script += [{0x181: 1}] * 100_000  # more SYNCs than 1 s of the prime can send
    seen: list[int] = []  # the axis has a sample once a frame on 0x181 has come
    pacing.network.subscribe(0x181, lambda cob, data, ts: seen.append(cob))
    axis = types.SimpleNamespace(has_sample=lambda: bool(seen))
    with caplog.at_level("WARNING", logger="rig.host.pacing"):
        prime(pacing, [axis], [], 0.001)  # type: ignore[list-item]
    assert len(caplog.records) == 1 and "still owed 1 s after the first of" in caplog.text, caplog.text
    assert "on 0x281" in caplog.text and "0x181" not in caplog.text
    assert not pacing.owes()
    script.clear()  # every later SYNC answered on both
    pacing.tick()
    assert not pacing.late


def test_a_tpdo_that_does_not_answer_every_sync_is_not_awaited(caplog: pytest.LogCaptureFixture) -> None:
    """CiA 301 0x1800 sub 2: a TPDO of transmission type n (2-240) answers every n-th SYNC,
    counted from a start the host does not know (254/255: on an event). The drive's TPDOs
    (type 1, the host's setting) are awaited; the encoder's TPDO2 set to type 2 is not (logged):
    awaited, every other cycle was late and its owed answers grew without end (the late-cycle
    stop), for frames the node never sends."""
    bench = LockstepBench("dc-servo")
    drive = Cia402Axis("motor", bench.host, 1, mode="voltage")
    encoder = Cia406Axis("encoder", bench.host, 2, period=bench.period)
    try:
        drive.setup()
        encoder.node.sdo[0x1801][2].raw = 2  # the node's TPDO2: every second SYNC
        encoder.setup()
        assert list(drive.tpdo_cob_ids()) == [0x181, 0x281] and encoder.tpdos_not_awaited() == [(0x282, 2)]
        with caplog.at_level("WARNING", logger="rig.host.pacing"):
            pacing = HostSync(bench.host, [drive, encoder], 0.0)
        assert "node 2: TPDO 0x282 has transmission type 2 (every n-th SYNC, n = 2)" in caplog.text
        late = []
        for _ in range(6):
            pacing.tick()
            late.append(pacing.late)
        assert late == [False] * 6 and not pacing.owes()
        pacing.close()
    finally:
        for axis in (drive, encoder):
            axis.close()
        bench.close()


def test_the_response_is_split_in_the_drives_answer_and_the_host_s_time(
    bus: tuple[HostSync, list[dict[int, int]]],
) -> None:
    """``split``: the SYNC sent to the last awaited answer handed on, then that to the commands'
    send; NaN for both where the answer was late (a late cycle's answer is not its SYNC's)."""
    import math
    import time

    pacing, script = bus
    script += [dict.fromkeys(COBS, 1), {0x181: 1}]
    pacing.tick()
    done = time.perf_counter()
    answer, host = pacing.split(done)
    assert not pacing.late and 0.0 <= answer < 1.0 and 0.0 <= host
    assert answer + host == pytest.approx(done - pacing.sent_at)
    pacing.tick()
    assert pacing.late and all(math.isnan(x) for x in pacing.split(time.perf_counter()))
