"""The bus time of a frame (worst-case stuffing) and a bus that books no more than its bit rate."""

from __future__ import annotations

import can
import pytest

from drivers.bus_time import BusTime, frame_bits


@pytest.mark.parametrize(
    ("extended", "dlc", "bits"),
    [
        (False, 8, 135),  # 47 + 64 bits, 24 stuff bits at worst: the figure schedulability tables give
        (False, 0, 55),  # 47 bits, 8 stuff bits
        (False, 1, 65),
        (True, 8, 160),  # 67 + 64 bits, 29 stuff bits
        (True, 0, 80),
    ],
)
def test_a_frame_holds_the_bus_for_its_bits_with_stuffing_at_its_worst(
    extended: bool, dlc: int, bits: int
) -> None:
    msg = can.Message(arbitration_id=0x123, is_extended_id=extended, data=bytes(dlc), dlc=dlc)
    assert frame_bits(msg) == bits


def test_a_remote_frame_carries_no_data_bits() -> None:
    msg = can.Message(arbitration_id=0x123, is_extended_id=False, is_remote_frame=True, dlc=8)
    assert frame_bits(msg) == 55


def test_the_bus_books_frames_back_to_back_and_holds_a_sender_past_its_burst() -> None:
    """At 125 kbit/s an 8-byte frame takes 1.08 ms; 2 ms may be booked ahead."""
    bus = BusTime(125_000, burst=0.002)
    frame = can.Message(arbitration_id=0x7FF, is_extended_id=False, data=bytes(8))
    assert bus.wait(10.0) == 0.0  # an idle bus
    for _ in range(3):
        bus.carry(frame, 10.0)
    assert bus.free_at == pytest.approx(10.0 + 3 * 135 / 125_000)
    assert bus.wait(10.0) == pytest.approx(3 * 135 / 125_000 - 0.002)  # hold the next 1.24 ms
    assert bus.wait(10.01) == 0.0  # the bus went idle meanwhile
    bus.carry(frame, 10.01)  # an idle bus books from now, not from the end of the old frames
    assert bus.free_at == pytest.approx(10.01 + 135 / 125_000)
    assert bus.frames == 4 and bus.busy == pytest.approx(4 * 135 / 125_000)


@pytest.mark.parametrize(("bitrate", "burst"), [(0.0, 0.002), (-1.0, 0.002), (1e6, -1.0)])
def test_a_bus_that_cannot_work_is_refused(bitrate: float, burst: float) -> None:
    with pytest.raises(ValueError, match=r"bit rate|burst"):
        BusTime(bitrate, burst=burst)
