"""can-utils (candump, cansend, cangen, asc2log; C, from the Linux-CAN project) on vcan0 against
``rig emulate`` in its own process and drive-rig's host.

can-utils know nothing of drive-rig or of python-canopen: ``candump -L`` logs what is on the bus,
``cansend`` puts exactly the bytes CiA 301 prescribes on it, ``cangen`` puts garbage on it. What
drive-rig and its emulator send is decoded here frame by frame from the standard, not from our
code; what they answer is checked byte by byte against CiA 301.

Needs vcan0 (the VM of ``.ci/run``, or ``modprobe vcan`` on Linux) and ``apt-get install can-utils``.
"""

from __future__ import annotations

import json
import pathlib
import subprocess
from collections.abc import Callable

import can
import canopen
import pytest

from drivers.bus import open_bus
from drivers.maps import CIA402_EDS, CIA406_EDS
from rig.cli import main
from rig.host.session import Session
from tests.interop.conftest import CanDump, Frame, cansend, need_tools, parse_log_line
from tests.vcan.conftest import lockstep_servo

pytestmark = [pytest.mark.interop, pytest.mark.timeout(600)]  # the VM is slow

HOST_NODE = 127  #: the host's heartbeat id ([bus] host_node)
NMT_STATES = {0x00: "BOOT-UP", 0x04: "STOPPED", 0x05: "OPERATIONAL", 0x7F: "PRE-OPERATIONAL"}


# --- the frames CiA 301 allows on this bus ---------------------------------------------------------
def pdo_lengths(network: canopen.Network, nodes: dict[int, str]) -> dict[int, int]:
    """COB-ID -> data length [bytes] of every enabled PDO, from the mappings in force on the devices
    (read by SDO: 0x1400-0x1BFF)."""
    lengths: dict[int, int] = {}
    for node_id, eds in nodes.items():
        node = canopen.RemoteNode(node_id, eds)
        node.sdo.RESPONSE_TIMEOUT = 2.0
        network.add_node(node)
        for maps in (node.tpdo, node.rpdo):
            maps.read()
            for pdo in maps.values():
                if pdo.enabled:
                    lengths[pdo.cob_id] = sum(var.length for var in pdo.map) // 8
        del network[node_id]
    return lengths


def classify(frame: Frame, pdos: dict[int, int], nodes: set[int]) -> str:
    """What ``frame`` is by CiA 301's predefined connection set; AssertionError if it is not allowed."""
    cid, n = frame.can_id, len(frame.data)
    assert not frame.remote, f"{frame}: a remote frame"
    node = cid & 0x7F
    if cid == 0x000:
        assert n == 2 and frame.data[0] in (0x01, 0x02, 0x80, 0x81, 0x82), f"{frame}: not an NMT command"
        return "NMT"
    if cid == 0x080:
        assert n == 0, f"{frame}: a SYNC with data"
        return "SYNC"
    if cid in pdos:
        assert n == pdos[cid], f"{frame}: PDO of {n} bytes, its mapping {pdos[cid]}"
        return "PDO"
    if 0x081 <= cid <= 0x0FF and node in nodes:
        assert n == 8, f"{frame}: EMCY of {n} bytes"
        return "EMCY"
    if 0x581 <= cid <= 0x5FF or 0x601 <= cid <= 0x67F:
        assert n == 8, f"{frame}: SDO of {n} bytes"
        return "SDO"
    if 0x701 <= cid <= 0x77F:
        assert n == 1 and frame.data[0] in NMT_STATES, f"{frame}: not a heartbeat (1 byte, a valid state)"
        return "BOOT-UP" if frame.data[0] == 0 else "HEARTBEAT"
    raise AssertionError(f"{frame}: no CANopen service of this bus uses this COB-ID")


def test_candump_decodes_scan_and_run_and_the_trace_reads_back(
    candump: CanDump,
    start_emulator: Callable[..., subprocess.Popen[str]],
    tmp_path: pathlib.Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """candump -L during the emulator's boot, ``rig scan`` and a short lock-step ``rig run``: every
    frame decoded by CiA 301. The run's trace.asc read back by python-can's ASCReader and by
    can-utils' asc2log: the frames candump logged while the run traced, each with the direction its
    COB-ID gives it (the host sends NMT, SYNC, RPDOs, SDO requests and its heartbeat), the sent ones
    in the bus's order and the received ones in the bus's order, the two interleaved as on the bus
    but for frames that crossed (``CROSSING``)."""
    need_tools("asc2log")
    start = candump.mark()
    _, wire = lockstep_servo(start_emulator, str(tmp_path))

    assert main(["scan", "--interface", "socketcan", "--channel", "vcan0", "--listen", "1.5", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    # in lock-step the emulator's clock, and so its heartbeat, stands still until the first SYNC:
    # the state is known from a heartbeat only (test_independent_canopen checks it)
    assert [(r["node_id"], r["profile"], r["vendor_id"]) for r in rows] == [
        (1, "CiA 402 drive", "0x00000DB1"),
        (2, "CiA 406 encoder", "0x00000DB1"),
    ]

    run_start = candump.mark()
    with Session(wire, emulate=False, duration=0.1) as session:
        session.start()
        summary = session.run()
    assert summary["safe_stop_reason"] is None and summary["cycles"] == 250
    end = candump.mark()

    network = canopen.Network(open_bus("socketcan", "vcan0"))
    network.connect()
    try:
        pdos = pdo_lengths(network, {1: CIA402_EDS, 2: CIA406_EDS})
    finally:
        network.disconnect()

    frames = [f for f in candump.snapshot()[start + 1 : end] if f.can_id != CanDump.MARK_ID]
    kinds = [classify(f, pdos, {1, 2, HOST_NODE}) for f in frames]
    # boot-up: the first frame of each node is 0x700+id with one 0x00 byte
    for node_id in (1, 2):
        first = next(
            f
            for f in frames
            if f.can_id & 0x780 != 0x600 and f.can_id & 0x7F == node_id and f.can_id != 0x080
        )
        assert (first.can_id, first.data) == (0x700 + node_id, b"\x00"), f"node {node_id} began with {first}"
    counts = {k: kinds.count(k) for k in sorted(set(kinds))}
    print(f"\ncandump during boot, rig scan and a 250-cycle run: {len(frames)} frames {counts}")
    assert counts["SYNC"] >= 250 and counts["PDO"] >= 2 * 250 and counts["BOOT-UP"] == 2

    # the trace of the run against candump
    trace_path = pathlib.Path(summary["run_dir"]) / "trace.asc"
    traced = [(m.arbitration_id, bytes(m.data), m.is_rx) for m in can.ASCReader(str(trace_path))]
    done = subprocess.run(
        ["asc2log", "-I", str(trace_path)], capture_output=True, text=True, check=True, timeout=60
    )
    converted = []
    for line in done.stdout.splitlines():
        *head, direction = line.split()
        frame = parse_log_line(" ".join(head))
        assert direction in ("R", "T"), line
        converted.append((frame.can_id, frame.data, direction == "R"))
    assert converted == traced, "asc2log and python-can's ASCReader read trace.asc differently"

    bus = [(f.can_id, f.data, not host_sends(f)) for f in candump.snapshot()[run_start + 1 : end]]
    shift = trace_against_bus(traced, bus)
    print(
        f"trace.asc: {len(traced)} frames ({sum(1 for t in traced if not t[2])} Tx), the same on the bus;"
        f" at most {shift} frames apart where a received frame crossed a sent one"
    )
    assert shift <= CROSSING, f"trace.asc and the bus interleave Tx and Rx {shift} frames apart"


#: how far apart (in frames) the trace and the bus may interleave a received frame and a sent one:
#: the trace logs a Tx frame when the host sends it and an Rx frame when python-can's notifier
#: thread hands it over, so a heartbeat that crosses an SDO request on the wire may be logged on
#: either side of it (seen in CI: node 1's heartbeat logged after the host's next SDO request)
CROSSING = 8


def trace_against_bus(traced: list[tuple[int, bytes, bool]], bus: list[tuple[int, bytes, bool]]) -> int:
    """Check that each direction of the trace is the bus's frames of that direction, in the same
    order and none missing (a wrong direction in the trace puts a frame in the wrong one); return
    the largest distance between a traced frame's place in the trace and its place on the bus."""
    places: dict[int, int] = {}
    for rx in (False, True):
        mine = [i for i, t in enumerate(traced) if t[2] == rx]
        theirs = [j for j, b in enumerate(bus) if b[2] == rx]
        want = [traced[i][:2] for i in mine]
        got = [bus[j][:2] for j in theirs]
        side = "Rx" if rx else "Tx"
        assert want, f"the trace has no {side} frames"
        assert want[0] in got, f"the trace's first {side} frame {want[0]} is not on the bus"
        first = got.index(want[0])
        assert got[first : first + len(want)] == want, f"the trace's {side} frames differ from the bus's"
        places.update(zip(mine, theirs[first : first + len(want)]))
    bus_order = sorted(places, key=places.__getitem__)
    return max(abs(rank - i) for rank, i in enumerate(bus_order))


def host_sends(frame: Frame) -> bool:
    """The host's frames: NMT, SYNC, RPDOs (0x200-0x57F less the TPDOs), SDO requests, its heartbeat."""
    cid = frame.can_id
    function = cid & 0x780
    return (
        cid in (0x000, 0x080, 0x700 + HOST_NODE)
        or function in (0x200, 0x300, 0x400, 0x500)
        or function == 0x600
    )


@pytest.fixture
def drive(can_tools: None, start_emulator: Callable[..., subprocess.Popen[str]]) -> CanDump:
    """The dc-servo preset on vcan0 (real time: drive node 1, encoder node 2) and candump."""
    dump = CanDump()
    start = dump.mark()
    start_emulator("--preset", "dc-servo")
    dump.wait(lambda f: f.can_id == 0x702 and f.data == b"\x00", start, "node 2's boot-up")
    yield dump  # type: ignore[misc]
    dump.close()


class Sdo:
    """SDO requests by cansend, answers from candump: CiA 301's bytes, nothing of ours."""

    def __init__(self, dump: CanDump, node_id: int) -> None:
        self.dump, self.node_id = dump, node_id

    def request(self, *data: int) -> bytes:
        start = self.dump.mark()
        payload = bytes(data).ljust(8, b"\x00").hex()
        cansend("vcan0", f"{0x600 + self.node_id:03X}#{payload}")
        _, answer = self.dump.wait(lambda f: f.can_id == 0x580 + self.node_id, start, "an SDO answer")
        assert len(answer.data) == 8, answer
        return answer.data

    def upload(self, index: int, sub: int) -> bytes:
        """Expedited or segmented upload; the data."""
        mux = [index & 0xFF, index >> 8, sub]
        first = self.request(0x40, *mux)
        assert first[:1] != b"\x80", (
            f"upload 0x{index:04X}:{sub}: abort 0x{int.from_bytes(first[4:], 'little'):08X}"
        )
        assert first[0] & 0xE0 == 0x40 and list(first[1:4]) == mux, first.hex()
        if first[0] & 0x02:  # expedited: 4 - n bytes
            size = 4 - ((first[0] >> 2) & 0x3) if first[0] & 0x01 else 4
            return first[4 : 4 + size]
        size = int.from_bytes(first[4:], "little") if first[0] & 0x01 else None
        data = b""
        toggle = 0
        while True:
            seg = self.request(0x60 | toggle << 4)
            assert seg[0] & 0xE0 == 0x00 and (seg[0] >> 4) & 1 == toggle, f"segment {seg.hex()}"
            data += seg[1 : 8 - ((seg[0] >> 1) & 0x7)]
            toggle ^= 1
            if seg[0] & 0x01:
                break
        assert size is None or len(data) == size
        return data

    def abort_code(self, answer: bytes) -> int:
        assert answer[0] == 0x80, f"no abort: {answer.hex()}"
        return int.from_bytes(answer[4:], "little")


def test_cansend_sdo_transfers_and_aborts(drive: CanDump) -> None:
    sdo = Sdo(drive, 1)
    # expedited upload: 0x1000 device type, 4 bytes
    assert sdo.request(0x40, 0x00, 0x10, 0x00) == bytes.fromhex("43001000") + (0x00020192).to_bytes(
        4, "little"
    )
    # segmented upload: 0x1008 the device name (more than 4 bytes)
    assert sdo.upload(0x1008, 0) == b"drive-rig emulated servo drive"
    # expedited download: 0x1017 heartbeat 250 ms (2 bytes, n = 2), read back
    assert sdo.request(0x2B, 0x17, 0x10, 0x00, 0xFA, 0x00) == bytes.fromhex("6017100000000000")
    assert sdo.upload(0x1017, 0) == (250).to_bytes(2, "little")
    # segmented download: 0x607A target position, 4 bytes in one last segment (n = 3, c = 1)
    assert sdo.request(0x21, 0x7A, 0x60, 0x00, 4, 0, 0, 0) == bytes.fromhex("607A600000000000")
    assert sdo.request(0x07, 0x78, 0x56, 0x34, 0x12) == bytes.fromhex("2000000000000000")
    assert sdo.upload(0x607A, 0) == bytes.fromhex("78563412")
    # aborts: a missing object, a read-only object, a wrong length
    assert sdo.abort_code(sdo.request(0x40, 0xFF, 0x2F, 0x00)) == 0x06020000
    assert sdo.abort_code(sdo.request(0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4)) == 0x06010002
    assert sdo.abort_code(sdo.request(0x23, 0x17, 0x10, 0x00, 1, 2, 3, 4)) in (0x06070010, 0x06070012)
    assert sdo.abort_code(sdo.request(0x2F, 0x17, 0x10, 0x00, 1)) in (0x06070010, 0x06070013)
    assert sdo.upload(0x1017, 0) == (250).to_bytes(2, "little")  # the refused writes took nothing


def test_cansend_nmt_states_heartbeats_and_boot_up(drive: CanDump) -> None:
    """NMT commands by cansend; the heartbeat states and boot-ups CiA 301 prescribes, and the
    reset of application (reset node) or communication (reset communication) parameters."""
    sdo = Sdo(drive, 1)

    def command(cs: int, node: int, expect: dict[int, int]) -> None:
        start = drive.mark()
        cansend("vcan0", f"000#{cs:02X}{node:02X}")
        for node_id, state in expect.items():
            drive.wait(
                lambda f, n=node_id, s=state: f.can_id == 0x700 + n and f.data == bytes([s]),
                start,
                f"node {node_id} in state 0x{state:02X} after NMT 0x{cs:02X} to node {node}",
            )

    command(0x01, 1, {1: 0x05})  # start
    command(0x02, 1, {1: 0x04})  # stop
    command(0x80, 1, {1: 0x7F})  # pre-operational
    command(0x01, 0, {1: 0x05, 2: 0x05})  # broadcast start
    command(0x80, 0, {1: 0x7F, 2: 0x7F})  # broadcast pre-operational
    # reset communication: boot-up, 0x1017 back to its default, 0x607A (application) kept
    sdo.request(0x2B, 0x17, 0x10, 0x00, 0x32, 0x00)  # 50 ms
    sdo.request(0x23, 0x7A, 0x60, 0x00, 0x11, 0x22, 0x33, 0x44)
    command(0x82, 1, {1: 0x00})
    command(0x80, 1, {1: 0x7F})  # and heartbeats go on
    assert sdo.upload(0x1017, 0) == (100).to_bytes(2, "little")
    assert sdo.upload(0x607A, 0) == bytes.fromhex("11223344")
    # reset node: boot-up and the application's objects reset too
    command(0x81, 1, {1: 0x00})
    assert sdo.upload(0x607A, 0) == bytes(4)
    command(0x81, 0, {1: 0x00, 2: 0x00})  # broadcast reset node: both boot
    # the boot-up is followed by heartbeats in PRE-OPERATIONAL
    command(0x80, 0, {1: 0x7F, 2: 0x7F})
