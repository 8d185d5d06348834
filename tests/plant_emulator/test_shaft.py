"""The shaft: piecewise stepping of a period, and one advance per SYNC whatever the node order."""

from __future__ import annotations

import random

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


@pytest.mark.parametrize("later", [0.3, 0.6])
def test_realtime_one_period_per_sync_whenever_its_other_nodes_handle_it(later: float) -> None:
    """Real time: a SYNC that its shaft's second node (the encoder beside the drive) handles
    ``later`` periods after the first moves neither the world nor the periods' phase again. It
    did: the second node's call re-locked the phase to its own later time, and advanced a period
    of its own where it came half a period or more after the first's, so the world drifted off
    the host's SYNCs by whole periods (here 5.3 and 6 periods in 5; across processes a 0.4 ms
    servo's answers stayed a period behind its SYNCs after a late cycle, and its rms error was
    twice lock-step's)."""
    log: list[tuple[object, ...]] = []
    motion = Recorder(log, "m")
    period = 1.0
    shaft = Shaft(motion, period=period)
    now = [0.0]
    shaft.clock = lambda: now[0]
    drive, encoder = object(), object()
    for k in range(1, 6):
        now[0] = k * period  # each SYNC on time: the drive's node handles it at once ...
        shaft.sync(drive, 100.0 + k)
        now[0] = (k + later) * period  # ... the encoder's node later, the same SYNC
        shaft.sync(encoder, 100.0 + k)
    assert motion.x == pytest.approx(5 * period)  # the clock's time: one period per SYNC
    assert shaft.t == pytest.approx(5 * period)  # the phase is the SYNC's, as its first node saw it


def test_realtime_periods_keep_to_the_syncs_grid_whatever_their_jitter() -> None:
    """Real time: 2,000 SYNCs on a host's grid of periods, each late by 0 to 0.7 periods (a
    loaded host), advance the world by as many periods as the grid's, within one. Each SYNC's
    rounding to its nearest boundary used to be kept for good (the phase moved all the way to
    every SYNC): a SYNC 0.6 periods late then one 0.2 late made three periods of two, and the
    count walked off the host's (here by tens of periods; across processes at 0.4 ms under
    load, by up to five in 10 s)."""
    log: list[tuple[object, ...]] = []
    motion = Recorder(log, "m")
    shaft = Shaft(motion, period=1.0)
    now = [0.0]
    shaft.clock = lambda: now[0]
    rng = random.Random(7)
    late = [0.0]
    for k in range(1, 2001):
        late[0] = rng.choice((0.0, 0.05, 0.1, 0.2, 0.6, 0.7)) if rng.random() < 0.5 else late[0]
        now[0] = k + late[0]
        shaft.sync(motion, now[0])
    assert abs(motion.x - 2000.0) <= 1.0


class Idle:
    """A drive on the shaft without commands."""

    def take_timeline(self, t_start: float) -> list[Timed]:
        return []

    def on_period(self) -> None:
        pass


def test_in_real_time_the_loads_time_at_the_runs_first_sync_is_one_period() -> None:
    """A load's time counts from the enable; in real time from the first SYNC after it, the
    run's first, which a real-time host sends tens of ms after its enable (here 64 periods): the
    loads' time there is one period, as at lock-step's first SYNC (which ends the world's first
    period). Counted from the enable, a load at 1.5 s stepped in 26 ms early in a 0.4 ms run
    compared with lock-step's."""
    shaft = Shaft(Recorder([], "m"), period=1.0)
    drive = Idle()
    shaft.attach(drive)
    now = [10.0]
    shaft.clock = lambda: now[0]
    shaft.t = now[0]
    shaft.enabled(drive)
    assert shaft.load_origin == 10.0  # a load runs from the enable until the run begins
    now[0] = 74.0
    shaft.advance_to(now[0])
    shaft.sync(drive, 1.0)  # the run's first SYNC
    assert shaft.load_origin is not None and shaft.t - shaft.load_origin == pytest.approx(1.0)
    now[0] = 75.0
    shaft.sync(drive, 2.0)  # the next: the origin stays
    assert shaft.t - shaft.load_origin == pytest.approx(2.0)
