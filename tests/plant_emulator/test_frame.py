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


def test_the_in_process_wire_finds_the_nodes_canopens_scanner_finds() -> None:
    """``attach_network`` skips canopen's scanner where it would add nothing: the nodes found
    are those canopen's own ``notify`` finds, from the same frames."""
    import canopen

    from plant_emulator.lockstep import SyncHub, attach_network

    ids = [0x080, 0x000, 0x201, 0x701, 0x585, 0x183, 0x181, 0x703, 0x30A, 0x48B, 0x700, 0x0FF]
    hub = SyncHub()
    ours, sender = canopen.Network(), hub.bus(channel="sender")
    attach_network(ours, hub.bus(queue=False, channel="ours"))
    theirs = canopen.Network()
    try:
        for can_id in ids:
            sender.send(Frame(can_id, b"\x05"))
            theirs.notify(can_id, bytearray(b"\x05"), 0.0)
    finally:
        sender.shutdown()
        ours.bus.shutdown()
    assert ours.scanner.nodes == theirs.scanner.nodes == [1, 5, 3, 11, 127]  # 0x0FF: EMCY of 127
