"""``Frame``: the same message as ``can.Message(arbitration_id=..., data=..., is_extended_id=False)``."""

from __future__ import annotations

import can
import pytest

from plant_emulator.frame import Frame

FIELDS = [s for s in can.Message.__slots__ if s != "__weakref__"]


@pytest.mark.parametrize("data", [b"", b"\x01", bytes(range(8)), bytearray(b"\x0f\x00"), [1, 2, 3]])
def test_a_frame_is_the_message_can_message_makes(data: object) -> None:
    ours = Frame(0x181, data)  # type: ignore[arg-type]
    theirs = can.Message(arbitration_id=0x181, data=data, is_extended_id=False)  # type: ignore[arg-type]
    assert isinstance(ours, can.Message)
    assert {f: getattr(ours, f) for f in FIELDS} == {f: getattr(theirs, f) for f in FIELDS}
    assert ours.equals(theirs)
    if isinstance(data, bytearray):  # kept, as can.Message keeps it
        assert ours.data is data and theirs.data is data
