"""The run's CAN trace: the same lines as python-can's ASCWriter, and python-can's ASCReader reads them."""

from __future__ import annotations

import pathlib

import can

from rig.host.trace import AscTrace

FRAMES = [
    can.Message(timestamp=100.0, arbitration_id=0x80, data=b"", is_extended_id=False, channel="host"),
    can.Message(timestamp=100.0004, arbitration_id=0x281, data=bytes(range(8)), is_extended_id=False),
    can.Message(
        timestamp=100.0008,
        arbitration_id=0x201,
        data=b"\x0f\x00\xe8\x03",
        is_extended_id=False,
        channel="emulator",
        is_rx=False,
    ),
    can.Message(timestamp=100.0012, arbitration_id=0x18FF1234, data=b"\x01", is_extended_id=True),
    can.Message(timestamp=100.0016, arbitration_id=0x701, is_remote_frame=True, dlc=1, is_extended_id=False),
    can.Message(timestamp=100.0020, arbitration_id=0x701, data=b"\x05", is_extended_id=False, channel="can1"),
    can.Message(timestamp=100.0024, is_error_frame=True),
]


def _lines(path: pathlib.Path) -> list[str]:
    return [line for line in path.read_text().splitlines() if not line.startswith(("date", "Begin"))]


def test_the_fast_path_writes_python_cans_lines(tmp_path: pathlib.Path) -> None:
    ours, theirs = tmp_path / "ours.asc", tmp_path / "theirs.asc"
    for path, cls in ((ours, AscTrace), (theirs, can.ASCWriter)):
        writer = cls(str(path))
        for msg in FRAMES:
            writer.on_message_received(msg)
        writer.stop()
    assert _lines(ours) == _lines(theirs)
    read = list(can.ASCReader(str(ours)))
    assert [m.arbitration_id for m in read if not m.is_error_frame] == [
        m.arbitration_id for m in FRAMES if not m.is_error_frame
    ]
    assert read[1].data == bytes(range(8)) and abs(read[1].timestamp - 0.0004) < 1e-9
