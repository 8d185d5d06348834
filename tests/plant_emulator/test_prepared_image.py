"""The emulated drive answers a SYNC from a state prepared ahead (``WorldClock.prepare``), as a
drive's firmware does: on the emulator's clock (injected here), the period ending at the next SYNC
is computed ``lead`` before it, so the SYNC is a latch and a send; and its TPDOs are the very
bytes the SYNC would have computed itself, bit for bit, in every mode the run uses, with a SYNC
jittering around its boundary."""

from __future__ import annotations

import random

import pytest

from plant_emulator.shaft import Shaft
from tests.plant_emulator.test_realtime_clock import World


def _frames(
    prepare: bool, mode: int, index: int, value: int, monkeypatch: pytest.MonkeyPatch
) -> tuple[dict[int, list[bytes]], int]:
    """The synchronous TPDOs of 300 SYNCs by COB-ID (the event TPDO of the statusword goes when
    the state changes, a lead earlier where prepared, as on a drive), and how many periods were
    computed while a SYNC was handled."""
    w = World()
    frames: dict[int, list[bytes]] = {0x281: [], 0x381: []}
    in_sync = [False]
    computed_in_sync = [0]
    advance = Shaft._advance

    def counted(self: Shaft, t: float, length: float | None = None) -> None:
        if in_sync[0]:
            computed_in_sync[0] += 1
        advance(self, t, length)

    monkeypatch.setattr(Shaft, "_advance", counted)
    try:
        w.hub.taps.append(
            lambda m: frames[m.arbitration_id].append(bytes(m.data)) if m.arbitration_id in frames else None
        )
        w.enable(mode)
        w.node.sdo[index].raw = value
        rng = random.Random(3)
        lead = w.clock.lead()
        for _ in range(300):
            boundary = w.clock.next_boundary()
            if prepare:
                w.time = boundary - lead
                w.clock.prepare()
            w.time = boundary + rng.uniform(-0.1, 0.1) * w.period  # the SYNC's jitter
            w.hub.clock = w.time
            in_sync[0] = True
            w.host.send_message(0x80, b"")
            in_sync[0] = False
        return frames, computed_in_sync[0]
    finally:
        w.close()


@pytest.mark.parametrize(
    ("mode", "index", "value"),
    [(-1, 0x2100, 4000), (9, 0x60FF, 20000), (8, 0x607A, 3000)],
    ids=["voltage", "csv", "csp"],
)
def test_the_prepared_answer_is_the_computed_one_bit_for_bit(
    mode: int, index: int, value: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    computed, work_at_sync = _frames(False, mode, index, value, monkeypatch)
    prepared, work_prepared = _frames(True, mode, index, value, monkeypatch)
    assert all(len(f) == 300 for f in computed.values())
    assert prepared == computed
    assert work_at_sync > 250 and work_prepared == 0  # the SYNC computed nothing once prepared
