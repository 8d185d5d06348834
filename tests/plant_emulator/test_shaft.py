"""The shaft: piecewise stepping of a period, and one advance per SYNC whatever the node order."""

from __future__ import annotations

import pytest

from plant_emulator.axes import Axis
from plant_emulator.shaft import Shaft, Timed, run_period


class Recorder(Axis):
    """An axis that records what it is asked to do."""

    modes = ()

    def __init__(self, log: list[tuple[object, ...]], name: str) -> None:
        self.log, self.name, self.x = log, name, 0.0

    def advance(self, h: float, t: float) -> None:
        self.log.append((self.name, "advance", round(h, 12), round(t, 12)))
        self.x += h

    def set_command(self, mode: int, value: complex | float, *, computed_one_sync_ago: bool = False) -> None:
        self.log.append((self.name, "command", mode, value, computed_one_sync_ago))

    def coast(self) -> None:
        self.log.append((self.name, "coast"))

    @property
    def position(self) -> float:
        return self.x


def test_run_period_applies_commands_at_their_offsets_in_a_stable_order() -> None:
    log: list[tuple[object, ...]] = []
    ax = Recorder(log, "a")
    timeline: list[Timed] = [(0.3, ax, 10, 2j, False), (0.0, ax, 10, 1j, True), (0.3, ax, 9, 3j, False)]
    run_period(ax.advance, timeline, 5.0, 1.0)
    assert log == [
        ("a", "advance", 0.0, 5.0),
        ("a", "command", 10, 1j, True),
        ("a", "advance", 0.3, 5.0),
        ("a", "command", 10, 2j, False),
        ("a", "advance", 0.0, 5.3),
        ("a", "command", 9, 3j, False),
        ("a", "advance", 0.7, 5.3),
    ]


class Drive:
    def __init__(self, timeline: list[Timed]) -> None:
        self.timeline = timeline

    def take_timeline(self, t_start: float) -> list[Timed]:
        out, self.timeline = self.timeline, []
        return out

    def on_period(self) -> None:
        pass


def test_one_advance_per_sync_whichever_node_comes_first() -> None:
    log: list[tuple[object, ...]] = []
    motion, source = Recorder(log, "motion"), Recorder(log, "source")
    shaft = Shaft(motion, sources=(source,), period=0.5)
    a, b = Drive([]), Drive([(0.25, source, 10, 1.0, False)])
    shaft.attach(a)
    shaft.attach(b)
    encoder = object()
    assert shaft.sync(a, 0.5) and not shaft.sync(encoder, 0.5) and not shaft.sync(b, 0.5)
    assert shaft.syncs == 1 and motion.x == 0.0  # nothing before the first SYNC
    assert shaft.sync(b, 1.0) and not shaft.sync(a, 1.0) and not shaft.sync(encoder, 1.0)
    assert motion.x == pytest.approx(0.5) and source.x == pytest.approx(0.5)
    # the sources step before the motion over each piece; the command splits the period
    assert [e[:2] for e in log] == [
        ("source", "advance"),
        ("motion", "advance"),
        ("source", "command"),
        ("source", "advance"),
        ("motion", "advance"),
    ]
    assert shaft.sync(encoder, 1.5) and motion.x == pytest.approx(1.0)
    assert shaft.sync(encoder, 1.5)  # the same node twice: a second SYNC with the same stamp
    assert motion.x == pytest.approx(1.5) and shaft.t == 1.5


def test_lockstep_time_is_the_sync_count() -> None:
    log: list[tuple[object, ...]] = []
    motion = Recorder(log, "m")
    shaft = Shaft(motion, period=0.25)
    shaft.lockstep = True
    shaft.load_origin = 0.0  # the loads' time running from 0 (as from a drive's enable at 0)
    for stamp in (100.0, 100.7, 101.1):  # wall-clock arrival times: noise
        shaft.sync(motion, stamp)
    assert shaft.t == 0.75 and log == [("m", "advance", 0.25, 0.25), ("m", "advance", 0.25, 0.5)]
    with pytest.raises(ValueError, match="period"):
        Shaft(motion, period=0.0)
