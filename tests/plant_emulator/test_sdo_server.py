"""The emulated drive's SDO server against CiA 301 (7.2.4.3), frame by frame: raw requests on
the in-process hub, every answer checked byte for byte (not through an SDO client, which would
hide what the server does with a request it should not get)."""

from __future__ import annotations

from collections.abc import Iterator

import can
import pytest

from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.lockstep import LockstepBench

NODE = 1  #: the dc-servo preset's drive
NAME = b"drive-rig emulated servo drive"  #: 0x1008, 30 bytes: a segmented upload
INIT_UPLOAD_1008 = "4008100000000000"
SEG = {0: "6000000000000000", 1: "7000000000000000"}  #: upload segment request, by toggle bit
CLIENT_ABORT_1008 = "8008100000000000"
#: the server's answers
INITIATED_1008 = "410810001e000000"  #: segmented, size indicated: 30
FIRST_SEGMENT = "00" + NAME[:7].hex()  #: toggle 0, 7 bytes, more to come
SECOND_SEGMENT = "10" + NAME[7:14].hex()
TOGGLE_ABORT = "8008100000000305"  #: 0x05030000 toggle bit not alternated
NO_TRANSFER_ABORT = "8008100001000405"  #: 0x05040001 command specifier not valid


class Client:
    """Raw SDO requests to node ``NODE``; ``answers`` are the hex data of its SDO answers since
    the last ``clear``."""

    def __init__(self, bench: LockstepBench) -> None:
        self.bus = bench.hub.bus(channel="client")
        self.answers: list[str] = []
        bench.hub.taps.append(self._tap)

    def _tap(self, msg: can.Message) -> None:
        if msg.arbitration_id == 0x580 + NODE:
            self.answers.append(bytes(msg.data).hex())

    def __call__(self, *requests: str) -> list[str]:
        """Send ``requests``; the answers that came meanwhile."""
        self.answers.clear()
        for hexdata in requests:
            data = bytes.fromhex(hexdata)
            self.bus.send(can.Message(arbitration_id=0x600 + NODE, data=data, is_extended_id=False))
        return list(self.answers)


@pytest.fixture
def bench() -> Iterator[LockstepBench]:
    b = LockstepBench("dc-servo")
    yield b
    b.close()


@pytest.fixture
def sdo(bench: LockstepBench) -> Iterator[Client]:
    client = Client(bench)
    yield client
    client.bus.shutdown()


def test_a_segmented_upload_and_no_segment_after_its_last(sdo: Client) -> None:
    answers = sdo(INIT_UPLOAD_1008, *(SEG[i % 2] for i in range(5)))
    assert answers[0] == INITIATED_1008
    data = b"".join(bytes.fromhex(a)[1 : 8 - (bytes.fromhex(a)[0] >> 1 & 7)] for a in answers[1:])
    assert data == NAME
    # the toggle bit alternates; the last: 2 bytes (n = 5), no more (c)
    assert [bytes.fromhex(a)[0] for a in answers[1:]] == [0x00, 0x10, 0x00, 0x10, 0x0B]
    # the transfer has ended: not an empty segment (canopen's server sent 1F 00 ...)
    assert sdo(SEG[1]) == [NO_TRANSFER_ABORT]


def test_a_new_initiate_restarts_the_upload(sdo: Client) -> None:
    assert sdo(INIT_UPLOAD_1008, SEG[0], INIT_UPLOAD_1008, SEG[0]) == [
        INITIATED_1008,
        FIRST_SEGMENT,
        INITIATED_1008,
        FIRST_SEGMENT,
    ]


def test_a_repeated_segment_request_is_a_toggle_error_that_ends_the_transfer(sdo: Client) -> None:
    """A client that sends a segment request again after its timeout (oze-canopen does) gets
    0x05030000, and the transfer is over: its next segment request is not answered with the
    aborted transfer's next segment (canopen's server went on with it)."""
    assert sdo(INIT_UPLOAD_1008, SEG[0], SEG[0]) == [INITIATED_1008, FIRST_SEGMENT, TOGGLE_ABORT]
    assert sdo(SEG[1]) == [NO_TRANSFER_ABORT]
    assert sdo(INIT_UPLOAD_1008, SEG[0], SEG[1]) == [INITIATED_1008, FIRST_SEGMENT, SECOND_SEGMENT]


def test_a_wrong_first_toggle_ends_the_transfer(sdo: Client) -> None:
    assert sdo(INIT_UPLOAD_1008, SEG[1]) == [INITIATED_1008, TOGGLE_ABORT]
    assert sdo(SEG[0]) == [NO_TRANSFER_ABORT]


def test_the_clients_abort_ends_the_transfer(sdo: Client) -> None:
    assert sdo(INIT_UPLOAD_1008, SEG[0], CLIENT_ABORT_1008) == [INITIATED_1008, FIRST_SEGMENT]  # no answer
    assert sdo(SEG[1]) == [NO_TRANSFER_ABORT]
    assert sdo(INIT_UPLOAD_1008, SEG[0]) == [INITIATED_1008, FIRST_SEGMENT]


def test_segment_requests_outside_a_transfer_of_their_direction(sdo: Client) -> None:
    # before any transfer: an abort at 0x0000:0 (canopen's server raised inside, no answer)
    assert sdo(SEG[0]) == ["8000000001000405"]
    assert sdo("0000000000000000") == ["8000000001000405"]  # download segment
    # after an expedited upload, and a download segment during an upload
    assert sdo("4000100000000000", SEG[0]) == ["4300100092010200", "8000100001000405"]
    assert sdo(INIT_UPLOAD_1008, "0000000000000000") == [INITIATED_1008, NO_TRANSFER_ABORT]


def test_a_segmented_download_and_no_segment_after_its_last(bench: LockstepBench, sdo: Client) -> None:
    # 0x1017 = 500 in one segment (size indicated 2; segment: toggle 0, n = 5, c)
    assert sdo("2117100002000000", "0bf4010000000000") == ["6017100000000000", "2000000000000000"]
    assert bench.devices[0].od.read(0x1017, 0) == 500
    assert sdo("1b00000000000000") == ["8017100001000405"]


def test_deferred_answers_come_once_each_in_order(bench: LockstepBench, sdo: Client) -> None:
    """Real time with a response time: requests that come faster than the answers (a client
    that retried a segment request after its timeout, as oze-canopen did in CI's VM) are
    answered once each, in order, after the response time; the retried request gets the toggle
    abort and the request after it the no-transfer abort, not the aborted transfer's data."""
    drive = bench.devices[0]
    assert isinstance(drive, EmulatedNode)
    now = [10.0]
    drive.clock_source = lambda: now[0]
    drive.sdo_delay = 0.001
    assert sdo(INIT_UPLOAD_1008, SEG[0], SEG[0], SEG[1]) == []
    drive.tick(now[0] + 0.0005)
    assert sdo.answers == []
    drive.tick(now[0] + 0.001)
    assert sdo.answers == [INITIATED_1008, FIRST_SEGMENT, TOGGLE_ABORT, NO_TRANSFER_ABORT]
