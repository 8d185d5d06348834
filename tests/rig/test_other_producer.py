"""Another producer on a COB-ID of the host's nodes is a safe stop named as such: a frame on a
TPDO's COB-ID its node did not send (more frames than the SYNCs allow, another length than the
mapping: ``drivers.producer_watch``), a sample whose position contradicts the drive's own speed
(``Cia402Cycle.foreign_sample``), and an RPDO of another length refused by the drive (its EMCY
0x8210, which is no fault of the drive's, in a run or in its stop).

In lock-step, deterministic: the independent fake device on python-can's virtual bus with a third
node's frame injected just before the device's TPDOs of a SYNC (``FakeDrive.inject``); the servo
in this process with a third bus on the lock-step wire. Across processes (timing tier): ``rig
emulate`` (the EPOS4 twin) and a real-time ``rig run``, a third socketcand client replaying the
drive's position TPDO with +0.3 rad, or flooding it."""

from __future__ import annotations

import json
import math
import pathlib
import re
import threading
import time
from collections.abc import Callable
from typing import Any

import can
import pytest

from drivers.cia402_setup import POSITION
from drivers.producer_watch import travel_band
from rig.config import load_config, rig_config
from rig.host.session import Session
from rig.papers.demo import demo_config, demo_doc
from tests.drivers.foreign import ForeignDrive
from tests.rig.test_other_master import _config, running_host


@pytest.fixture
def fake(tmp_path: pathlib.Path) -> Any:
    d = ForeignDrive("faulhaber-mc5004", tmp_path)
    yield d
    d.close()


def _moved(axis: Any, data: bytes, rad: float) -> bytes:
    """The TPDO frame ``data`` of ``axis``'s position with the position ``rad`` [rad] further on."""
    slot, place = axis.data.where(POSITION)
    values = list(slot.codec.unpack(data))
    values[place] += round(rad * axis.units.position)
    return bytes(slot.codec.pack(*values))


@pytest.mark.parametrize(
    ("what", "said"),
    [
        ("replay", r"(\d+) frames for (\d+) SYNCs, where type 1 answers once a SYNC"),
        ("short", r"a frame of 3 bytes where its mapping has \d+"),
    ],
)
def test_a_frame_its_node_did_not_send_on_a_tpdo_is_a_safe_stop(
    fake: ForeignDrive, tmp_path: pathlib.Path, what: str, said: str
) -> None:
    """A third node's frame on the drive's position TPDO just before the drive's own answer to a
    SYNC (the host takes it for the answer): the drive's answer is one frame more than the SYNCs;
    a frame of another length is not the drive's at all. Without the watch the drive's own
    answer replaced it before the cycle read it, and the run went on to its end."""
    with Session(load_config(_config(tmp_path, fake)), emulate=False, cycles=200) as session:
        session.start()
        axis = session.axes[0]
        slot, _ = axis.data.where(POSITION)  # type: ignore[attr-defined]
        frame = _moved(axis, bytes(slot.data), 0.3) if what == "replay" else b"\x01\x02\x03"
        fake.fake.inject[fake.fake.syncs + 50] = (slot.cob_id, frame)
        summary = session.run()
    assert 45 <= summary["cycles"] <= 55, summary["cycles"]
    reason = summary["safe_stop_reason"]
    cob = f"0x{slot.cob_id:03X}"
    assert re.fullmatch(
        rf"node 1: another producer on COB-ID {cob} \(a TPDO of node 1\): {said}, "
        "which node 1 did not send",
        reason,
    ), reason
    if what == "replay":
        frames, syncs = map(int, re.findall(r"(\d+) frames for (\d+) SYNCs", reason)[0])
        assert frames == syncs + 1
    assert summary["stop_confirmed"] is True and fake.fake.state == "SWITCH ON DISABLED"


def _third_bus(session: Session, on_frame: Callable[[Any, can.Message], None]) -> Any:
    """A third node on the in-process lock-step wire: ``on_frame(bus, msg)`` sees every frame."""
    assert session.transport.emulation is not None and session.transport.emulation.bench is not None
    other = session.transport.emulation.bench.hub.bus(queue=False, channel="other")
    other.listeners.append(lambda msg: on_frame(other, msg))
    return other


def _send(bus: Any, cob: int, data: bytes) -> None:
    bus.send(can.Message(arbitration_id=cob, data=data, is_extended_id=False))


def test_a_position_the_drive_s_speed_contradicts_is_another_producer(tmp_path: pathlib.Path) -> None:
    """The servo in lock-step: at 0.1 s a third node sends the drive's position TPDO again, right
    after the drive's own, 0.2 rad further on (less than the step no motor makes within the speed
    limit, 0.36 rad a period): the cycle takes it, and its position contradicts the drive's own
    speed 0x606C. Without the check it was the measurement, the run went on to its end."""
    with Session(demo_config(str(tmp_path)), emulate=True, duration=0.2) as session:
        session.start()
        axis = session.axes[0]
        slot, _ = axis.data.where(POSITION)  # type: ignore[attr-defined]
        hub = session.transport.emulation.bench.hub  # type: ignore[union-attr]
        sent: list[bytes] = []

        def replay(bus: Any, msg: can.Message) -> None:
            if msg.arbitration_id == slot.cob_id and hub.clock >= 0.1 and not sent:
                sent.append(_moved(axis, bytes(msg.data), 0.2))
                _send(bus, slot.cob_id, sent[0])

        _third_bus(session, replay)
        summary = session.run()
    assert sent and abs(summary["cycles"] - round(0.1 / session.timebase.period)) <= 1, summary["cycles"]
    reason = summary["safe_stop_reason"]
    assert re.fullmatch(
        rf"node 1: another producer on COB-ID 0x{slot.cob_id:03X} \(a TPDO of node 1\): the position moved "
        r"0\.(19|20)\d* rad in one period where the drive's own speed "
        r"\(0x606C: [-\d.e+]+, then [-\d.e+]+ rad/s\) and acceleration \(at most [\d.e+]+ rad/s\^2\) "
        r"allow [-\d.e+]+ to [-\d.e+]+ rad",
        reason,
    ), reason
    assert summary["stop_confirmed"] is True, summary


@pytest.mark.parametrize(("k", "period", "old_stop"), [(2.83, 2e-3, 38), (4.0, 2e-3, 23), (4.0, 1e-3, 119)])
def test_a_chattering_shaft_in_lock_step_is_no_other_producer(
    tmp_path: pathlib.Path, k: float, period: float, old_stop: int
) -> None:
    """The servo of examples/sweeps/servo_b_m.toml on plants of 2.83 and 4 times the design's b_m
    at 1 and 2 ms, in lock-step (no third node at all): its chattering shaft moves 3 counts in a
    period between two samples at zero speed (a speed that reverses or sticks and slips inside the
    period). The dc-servo drive declares its motor's most (0x60C5/0x60C6), which bounds that travel:
    no other producer. The bound of the two speeds alone stopped these runs after ``old_stop``
    cycles ('... 0x606C: 0, then 0 rad/s) allows -0.003069 to 0.003069 rad')."""
    doc = demo_doc(str(tmp_path))
    doc["emulator"]["params"].update(b_m=k * 680.0, period=period)
    cycles = old_stop + 30
    with Session(rig_config(doc, "test"), emulate=True, duration=cycles * period) as session:
        session.start()
        summary = session.run()
        accel = session.axes[0].max_acceleration  # type: ignore[attr-defined]
    assert summary["safe_stop_reason"] is None and summary["cycles"] == cycles, summary["safe_stop_reason"]
    assert 4.0e4 * k < accel < 1.0e5 * k  # b_m (u_max + k_e w) and the load over J: finite, said


def test_the_travel_band_of_a_shaft_that_reverses_inside_the_period() -> None:
    """Zero speed at both samples, |dv/dt| <= a: the shaft can go a dt^2/4 and come back to rest
    (a triangle of speed); known speeds at both ends bound it less; no acceleration said, no band."""
    a, dt, q = 1.0e5, 1e-3, (0.0, 0.0)
    assert travel_band(0.0, 0.0, dt, dt, resolution=q, accel=a) == pytest.approx(
        (-a * dt * dt / 4, a * dt * dt / 4)
    )
    lo, hi = travel_band(10.0, 10.0, dt, dt, resolution=q, accel=a)
    assert hi == pytest.approx(10.0 * dt + a * dt * dt / 4) and lo == pytest.approx(
        10.0 * dt - a * dt * dt / 4
    )
    lo, hi = travel_band(0.0, 100.0, dt, dt, resolution=q, accel=a)  # the change itself needs a dt
    assert lo == pytest.approx(0.5 * 100.0 * dt) and hi == pytest.approx(0.5 * 100.0 * dt)
    assert travel_band(0.0, 0.0, dt, dt, resolution=q, accel=math.inf) is None


@pytest.mark.parametrize("when", ["running", "stopping"])
def test_an_rpdo_the_drive_refused_for_its_length_is_another_producer_not_a_fault(
    tmp_path: pathlib.Path, when: str
) -> None:
    """A third node's frame of 3 bytes on the drive's RPDO: the drive does not process it and says
    so (CiA 301: EMCY 0x8210), nothing more. The host sends its RPDOs at their mapping's length:
    while running, a safe stop naming another producer on the node's RPDO (it was 'device fault');
    in the stop (after the host's quick stop), no fault of the drive's: the stop is confirmed by
    its state and rest (it was not, 'EMCY 0x8210 during the stop')."""
    with Session(demo_config(str(tmp_path)), emulate=True, duration=0.2) as session:
        session.start()
        axis = session.axes[0]
        rpdo = axis.data.rpdo.cob_id  # type: ignore[attr-defined]
        hub = session.transport.emulation.bench.hub  # type: ignore[union-attr]
        quick_stop = bytes([0x2B, 0x40, 0x60, 0x00, 0x02, 0x00, 0x00, 0x00])
        sent: list[float] = []

        def inject(bus: Any, msg: can.Message) -> None:
            due = (
                msg.arbitration_id == 0x080 and hub.clock >= 0.1
                if when == "running"
                else msg.arbitration_id == 0x601 and bytes(msg.data) == quick_stop
            )
            if due and not sent:
                sent.append(hub.clock)
                _send(bus, rpdo, b"\x01\x02\x03")

        _third_bus(session, inject)
        summary = session.run()
    assert sent and "EMCY 0x8210" in " ".join(axis.watch.emcy_log)  # type: ignore[attr-defined]
    reason = summary["safe_stop_reason"]
    if when == "running":
        assert re.fullmatch(
            r"node 1: another producer on an RPDO COB-ID of node 1: the node refused a PDO of another length "
            r"than its mapping \(EMCY 0x8210 \(PDO not processed due to length error\), error register "
            r"0x\w\w\), which this host did not send",
            reason,
        ), reason
    else:
        assert reason is None and summary["cycles"] == round(0.2 / session.timebase.period)
    assert summary["stop_confirmed"] is True, summary


# --- across processes -------------------------------------------------------------------------
class _Bystander:
    """A third socketcand client of ``rig emulate``: learns where the drive's position is (its
    TPDO mapping and position unit, by SDO) and replays or floods that TPDO."""

    def __init__(self, port: int, eds: str) -> None:
        from rig.faults.wire_probe import Watcher

        self.watcher = Watcher(port, pathlib.Path(eds))
        self.network = self.watcher.network
        self.cob, self.offset, self.per_rad = self._where_position()
        self.sent = 0
        self._stop = threading.Event()

    def _where_position(self) -> tuple[int, int, float]:
        """(COB-ID, byte offset, increments per rad) of 0x6064 in the TPDOs in force."""
        from drivers.cia402_units import discover_units
        from drivers.maps.cia import Mode

        read = self.watcher._read
        for n in range(4):
            count = read(0x1A00 + n, 0) or 0
            offset = 0
            for sub in range(1, count + 1):
                entry = read(0x1A00 + n, sub)
                if entry >> 16 == 0x6064:
                    cob = read(0x1800 + n, 1) & 0x7FF
                    units = discover_units(read, {}, where="node 1", mode=Mode.CSV)
                    return cob, offset, units.position
                offset += (entry & 0xFF) // 8
        raise AssertionError("no TPDO maps 0x6064")

    def moved(self, data: bytes, rad: float) -> bytes:
        out = bytearray(data)
        raw = int.from_bytes(out[self.offset : self.offset + 4], "little", signed=True)
        raw += round(rad * self.per_rad)
        out[self.offset : self.offset + 4] = raw.to_bytes(4, "little", signed=True)
        return bytes(out)

    def send(self, data: bytes) -> None:
        if not self._stop.is_set():
            self.network.send_message(self.cob, data)
            self.sent += 1

    def replay(self, rad: float) -> None:
        """Each of the drive's frames on the COB-ID sent again, the position ``rad`` further on."""
        self.network.subscribe(self.cob, lambda cob, data, ts: self.send(self.moved(bytes(data), rad)))

    def flood(self, rad: float, seconds: float) -> None:
        """The last frame seen, the position ``rad`` further on, as fast as the link takes it."""
        last: list[bytes] = []
        self.network.subscribe(self.cob, lambda cob, data, ts: last.append(bytes(data)))
        end = time.monotonic() + seconds
        while time.monotonic() < end and not self._stop.is_set():
            if last:
                self.send(self.moved(last[-1], rad))
            time.sleep(0)

    def close(self) -> None:
        self._stop.set()
        self.watcher.close()


@pytest.mark.timing
@pytest.mark.parametrize("how", ["replay", "flood"])
def test_a_replay_or_a_flood_of_the_position_tpdo_stops_a_run_across_processes(
    tmp_path: pathlib.Path, how: str
) -> None:
    """``rig emulate`` (the EPOS4 twin) and a real-time ``rig run`` at 20 rad/s; a third socketcand
    client replays the drive's position TPDO with +0.3 rad (each frame again), or floods it: the run
    ends in a safe stop naming another producer on that COB-ID, confirmed, exit 3 (the replay was
    the measurement in 29 % of cycles with exit 0; the flood was 'encoder glitch?')."""
    with running_host(tmp_path, 20.0) as (host, port, eds):
        other = _Bystander(port, eds)
        try:
            if how == "replay":
                other.replay(0.3)
            else:
                other.flood(0.3, 1.0)
            out, err = host.communicate(timeout=60)
        finally:
            other.close()
    assert other.sent > 0
    assert host.returncode == 3, err[-2000:]
    summary = json.loads(out)
    reason = summary["safe_stop_reason"]
    named = f"node 1: another producer on COB-ID 0x{other.cob:03X} (a TPDO of node 1): "
    assert reason.startswith(named), reason
    assert summary["stop_confirmed"] is True, (summary["still_turning"], err[-2000:])
