"""The host's heartbeat beats once per slot of cycles, whatever the cycle count does."""

from __future__ import annotations

from rig.host.heartbeat import HostHeartbeat


class _Network:
    def __init__(self) -> None:
        self.sent: list[tuple[int, bytes]] = []

    def send_message(self, cob_id: int, data: bytes) -> None:
        self.sent.append((cob_id, data))


def _beats(ks: list[int]) -> list[int]:
    net = _Network()
    hb = HostHeartbeat(net, 127, 0.1, 0.002)  # every 50 cycles
    out = []
    for k in ks:
        before = len(net.sent)
        hb.beat(k)
        if len(net.sent) > before:
            out.append(k)
    assert all(frame == (0x77F, b"\x05") for frame in net.sent)
    return out


def test_one_beat_per_50_cycles() -> None:
    assert _beats(list(range(151))) == [0, 50, 100, 150]


def test_a_real_time_loop_that_skipped_the_multiple_still_beats() -> None:
    """Overruns make ``k`` jump (49 -> 52): the beat is not lost with the skipped cycle."""
    assert _beats([0, 1, 49, 52, 53, 99, 103]) == [0, 52, 103]


def test_a_count_that_starts_again_beats_at_once() -> None:
    """The stop counts its cycles from 0 after the loop's: its first cycle beats."""
    assert _beats([0, 50, 120, 0, 1, 50]) == [0, 50, 120, 0, 50]
