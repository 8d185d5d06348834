"""Interpolated position mode (CiA 402 mode 7) of the emulated drive, by canopen's ``RemoteNode`` (a
client the toolkit did not write) on the dual-axis twin, lock-step: the buffer's semantics (a FIFO
taken one record an interpolation cycle, in order; underflow; a full buffer refusing; clear; a stop
emptying it), the linear interpolation over 0x60C2, and the refusals of what this drive does not
do (plant_emulator/interpolation.py's docstring)."""

from __future__ import annotations

import dataclasses
import pathlib
import re
from collections.abc import Iterator

import canopen
import pytest
from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps.cia import Controlword, Mode, PowerState, decode_statusword
from plant_emulator.device_profile import DeviceProfile, device_profile
from plant_emulator.lockstep import LockstepBench
from tests.plant_emulator.test_dual_axis_twin import map_rpdo

PROFILE = device_profile("dual-axis")
IP_ACTIVE, TARGET_REACHED, WARNING = 1 << 12, 1 << 10, 1 << 7
RUN, RUN_IP = int(Controlword.ENABLE_OPERATION), int(Controlword.ENABLE_OPERATION) | 0x10
DEVICE_STATE, VALUE_RANGE = 0x08000022, 0x06090030


@pytest.fixture
def bench() -> Iterator[LockstepBench]:
    b = LockstepBench(PROFILE.physics, device=PROFILE)
    yield b
    b.close()


def declaring(tmp_path: pathlib.Path, defaults: dict[str, int]) -> DeviceProfile:
    """The dual-axis twin with its EDS's DefaultValue of each section in ``defaults`` changed
    (``{"60C4sub1": 4}``): what the device declares."""
    text = PROFILE.eds.read_text()
    for section, value in defaults.items():
        text, n = re.subn(
            rf"(\[{section}\][^[]*?DefaultValue=)[^\n]*", rf"\g<1>{value}", text, flags=re.IGNORECASE
        )
        assert n == 1, section
    eds = tmp_path / "dual-axis.eds"
    eds.write_text(text)
    return dataclasses.replace(PROFILE, eds=eds)


def _ip(b: LockstepBench, offset: int = 0, eds: pathlib.Path = PROFILE.eds) -> canopen.RemoteNode:
    """Axis 1 (``offset`` 0x800: axis 2) OPERATION ENABLED in ip, bit 4 clear; 0x60C2 one period."""
    node = canopen.RemoteNode(1, str(eds))
    b.host.add_node(node)
    node.sdo[0x60C2 + offset][1].raw = 4  # 4 x 10^-4 s: the twin's period, one record a SYNC
    node.sdo[0x60C2 + offset][2].raw = -4
    node.sdo[0x6060 + offset].raw = int(Mode.INTERPOLATED_POSITION)
    for word in (Controlword.SHUTDOWN, Controlword.SWITCH_ON, Controlword.ENABLE_OPERATION):
        node.sdo[0x6040 + offset].raw = int(word)
    b.sync()
    assert decode_statusword(node.sdo[0x6041 + offset].raw) is PowerState.OPERATION_ENABLED
    return node


def _record(node: canopen.RemoteNode, value: int, offset: int = 0) -> None:
    node.sdo[0x60C1 + offset][1].raw = value


def _abort(code: int, write: object) -> None:
    with pytest.raises(SdoAbortedError) as err:
        write()  # type: ignore[operator]
    assert err.value.code == code


def test_the_records_are_taken_in_order_one_a_sync_then_the_last_is_held(bench: LockstepBench) -> None:
    """Records written with bit 4 clear wait (the demand 0x6062 holds where the motor stood); bit 4
    set, each SYNC takes the oldest: 0x6062 shows them in the order written. The FIFO dry, the
    demand holds at the last record, the motor comes to rest there, statusword bit 7 (warning)
    says the interpolation cycles pass without a record, bit 10 that the target is reached; a new
    record is taken at once and bit 7 clears."""
    node = _ip(bench)
    records = [100, 300, 200, 500, 400]
    for r in records:
        _record(node, r)
    assert node.sdo[0x60C4][4].raw == 5  # buffer position: the records waiting
    bench.sync()
    assert node.sdo[0x6062].raw == 0 and not node.sdo[0x6041].raw & IP_ACTIVE
    node.sdo[0x6040].raw = RUN_IP
    seen = []
    for _ in range(7):
        bench.sync()
        seen.append(node.sdo[0x6062].raw)
    assert seen == [*records, 400, 400]
    word = node.sdo[0x6041].raw
    assert word & IP_ACTIVE and word & WARNING  # an interpolation cycle passed without a record
    assert node.sdo[0x60C4][4].raw == 0
    for _ in range(1000):
        bench.sync()
    assert node.sdo[0x6064].raw == pytest.approx(400, abs=2)
    assert node.sdo[0x6041].raw & TARGET_REACHED
    _record(node, 650)  # the interpolator waits: taken at once, shown at the next SYNC
    bench.sync()
    assert node.sdo[0x6062].raw == 650 and not node.sdo[0x6041].raw & WARNING


def test_bit_4_clear_holds_and_the_records_wait(bench: LockstepBench) -> None:
    node = _ip(bench)
    node.sdo[0x6040].raw = RUN_IP
    _record(node, 100)
    _record(node, 200)
    bench.sync()
    node.sdo[0x6040].raw = RUN  # bit 4 clear: ip mode inactive, the demand held
    bench.sync()
    held = node.sdo[0x6062].raw
    _record(node, 300)
    for _ in range(3):
        bench.sync()
    assert node.sdo[0x6062].raw == held and not node.sdo[0x6041].raw & IP_ACTIVE
    assert node.sdo[0x60C4][4].raw == 1  # 300 waits (200 was taken)
    node.sdo[0x6040].raw = RUN_IP
    bench.sync()
    bench.sync()
    assert node.sdo[0x6062].raw == 300 and node.sdo[0x60C4][4].raw == 0


def test_a_full_buffer_refuses_a_record_by_sdo_and_drops_it_from_an_rpdo(bench: LockstepBench) -> None:
    """0x60C4:02 = 3: a fourth record by SDO is refused (0x08000022, the present device state); one
    in an RPDO, which cannot be refused, is dropped: the three are followed, never the fourth."""
    node = _ip(bench)
    node.sdo[0x60C4][2].raw = 3
    for r in (10, 20, 30):
        _record(node, r)
    _abort(DEVICE_STATE, lambda: _record(node, 40))
    assert node.sdo[0x60C4][4].raw == 3
    map_rpdo(node, 1, 0x201, [(0x6040, 0, 16), (0x60C1, 1, 32)])  # synchronous: controlword, 0x60C1:01
    node.nmt.state = "OPERATIONAL"
    bench.host.send_message(0x201, RUN.to_bytes(2, "little") + (50).to_bytes(4, "little"))
    bench.sync()
    assert node.sdo[0x60C4][4].raw == 3  # the RPDO's record dropped
    assert bench.devices[0].profiles.ip.refused == 2  # type: ignore[attr-defined]
    node.sdo[0x6040].raw = RUN_IP
    seen = []
    for _ in range(4):
        bench.sync()
        seen.append(node.sdo[0x6062].raw)
    assert seen == [10, 20, 30, 30]


def test_buffer_clear_empties_it_and_refuses_records_until_taken_again(bench: LockstepBench) -> None:
    node = _ip(bench)
    _record(node, 100)
    _record(node, 200)
    node.sdo[0x60C4][6].raw = 0  # clear: emptied, access disabled
    assert node.sdo[0x60C4][4].raw == 0
    _abort(DEVICE_STATE, lambda: _record(node, 300))
    node.sdo[0x60C4][6].raw = 1  # access enabled again
    _record(node, 400)
    node.sdo[0x6040].raw = RUN_IP
    bench.sync()
    assert node.sdo[0x6062].raw == 400


def test_leaving_operation_enabled_empties_the_buffer(bench: LockstepBench) -> None:
    """A quick stop: the records left are dropped (an interrupted profile never resumes), and
    none is taken outside OPERATION ENABLED."""
    node = _ip(bench)
    _record(node, 100)
    _record(node, 200)
    node.sdo[0x6040].raw = int(Controlword.QUICK_STOP)
    bench.sync()
    assert node.sdo[0x60C4][4].raw == 0
    _abort(DEVICE_STATE, lambda: _record(node, 300))


def test_a_record_is_interpolated_linearly_over_the_interpolation_period(bench: LockstepBench) -> None:
    """0x60C2 = 1.6 ms, four periods of the twin: a record of 400 from 0 is a demand of 100, 200,
    300, 400 in four SYNCs; the next record's segment starts there."""
    node = _ip(bench)
    node.sdo[0x60C2][1].raw = 16
    _record(node, 400)
    _record(node, 0)
    node.sdo[0x6040].raw = RUN_IP
    seen = []
    for _ in range(8):
        bench.sync()
        seen.append(node.sdo[0x6062].raw)
    assert seen == [100, 200, 300, 400, 300, 200, 100, 0]


def test_what_this_drive_does_not_do_is_refused(bench: LockstepBench) -> None:
    """Another sub-mode than linear, a ring buffer, a record of another size, a depth beyond the
    maximum: SDO abort 0x06090030; a record outside ip mode: 0x08000022."""
    node = _ip(bench)
    _abort(VALUE_RANGE, lambda: setattr(node.sdo[0x60C0], "raw", -1))
    _abort(VALUE_RANGE, lambda: setattr(node.sdo[0x60C4][3], "raw", 1))
    _abort(VALUE_RANGE, lambda: setattr(node.sdo[0x60C4][5], "raw", 8))
    _abort(VALUE_RANGE, lambda: setattr(node.sdo[0x60C4][2], "raw", node.sdo[0x60C4][1].raw + 1))
    assert node.sdo[0x60C3][1].raw == 0  # the general SYNC
    _abort(VALUE_RANGE, lambda: setattr(node.sdo[0x60C3][2], "raw", 2))  # an interpolation cycle every SYNC
    node.sdo[0x60C3][2].raw = 1
    node.sdo[0x6060].raw = int(Mode.CSP)
    bench.sync()
    _abort(DEVICE_STATE, lambda: _record(node, 100))


def test_each_axis_has_a_buffer_of_its_own(bench: LockstepBench) -> None:
    """Axis 2's objects (0x68C1, 0x68C4, 0x6862): its records are its own, axis 1 stays at rest."""
    node = _ip(bench, 0x800)
    for r in (1000, 2000):
        _record(node, r, 0x800)
    node.sdo[0x6840].raw = RUN_IP
    bench.sync()
    bench.sync()
    assert node.sdo[0x6862].raw == 2000 and node.sdo[0x68C4][4].raw == 0
    assert node.sdo[0x6062].raw == 0 and node.sdo[0x60C4][4].raw == 0
    assert decode_statusword(node.sdo[0x6041].raw) is PowerState.SWITCH_ON_DISABLED


def test_the_buffer_size_is_what_the_device_declares(tmp_path: pathlib.Path) -> None:
    """A drive whose EDS declares 0x60C4:01 = 4 (maximum buffer size) and 0x60C4:02 = 4: four
    records fill its FIFO and a fifth is refused; a depth of 5 is beyond what it has; a depth of 2
    (0x60C4:02, which empties the buffer) takes two. The buffer position 0x60C4:04 (CiA 402: the
    next free entry) counts the records waiting; a write to it has no effect in a FIFO."""
    profile = declaring(tmp_path, {"60C4sub1": 4, "60C4sub2": 4})
    bench = LockstepBench(profile.physics, device=profile)
    try:
        node = _ip(bench, eds=profile.eds)
        assert node.sdo[0x60C4][1].raw == 4
        for r in (1, 2, 3, 4):
            _record(node, r)
        _abort(DEVICE_STATE, lambda: _record(node, 5))
        node.sdo[0x60C4][4].raw = 0  # no effect: it shows the fill
        assert node.sdo[0x60C4][4].raw == 4
        _abort(VALUE_RANGE, lambda: setattr(node.sdo[0x60C4][2], "raw", 5))
        node.sdo[0x60C4][2].raw = 2
        assert node.sdo[0x60C4][4].raw == 0
        _record(node, 10)
        _record(node, 20)
        _abort(DEVICE_STATE, lambda: _record(node, 30))
        node.sdo[0x6040].raw = RUN_IP  # drained, one a SYNC, in order
        seen = []
        for _ in range(3):
            bench.sync()
            seen.append((node.sdo[0x6062].raw, node.sdo[0x60C4][4].raw))
        assert seen == [(10, 1), (20, 0), (20, 0)]
    finally:
        bench.close()


def test_the_interpolation_period_stands_while_ip_mode_is_active(bench: LockstepBench) -> None:
    """0x60C2 is written while ip mode is inactive (bit 4 clear), refused while it is active
    (0x08000022): the segment under way keeps its length."""
    node = _ip(bench)
    node.sdo[0x60C2][1].raw = 8  # inactive: taken
    node.sdo[0x6040].raw = RUN_IP
    bench.sync()
    _abort(DEVICE_STATE, lambda: setattr(node.sdo[0x60C2][1], "raw", 4))
    node.sdo[0x6040].raw = RUN
    node.sdo[0x60C2][1].raw = 4
    assert node.sdo[0x60C2][1].raw == 4
