"""The plant behind one or more nodes, advanced exactly once per SYNC period.

A ``Shaft`` is what the nodes on one shaft share: the axis whose model
integrates the motion (``motion``: a motor with its mechanics, e.g. (3.4) or
(4.2)) and the torque sources coupled to it (``sources``: a load machine whose
torque enters the motion's load torque). Drives hand it their commands, with
the instant each takes effect; encoders read its angle.

Per SYNC k every node on the shaft calls ``sync(node, timestamp)``. The first
of them advances the period [t_(k-1), t_k] for all: it collects every drive's
command timeline for that period (``take_timeline``: a synchronous RPDO at
offset 0, an event RPDO after its latency; a drive whose power stage is off
gives none and lets its axis coast) and steps the axes piecewise between the
commands (``run_period``). The others of the same SYNC find the shaft at t_k
already, so each node latches the state at the SYNC instant, whatever order
the nodes handle the frame in. The timelines are merged in the order the
drives were attached, so that order, not the handling order, breaks ties.

A drive built without one (``EmulatedDrive(shaft=None)``) gets a shaft of its
own: a solo drive and a coupled one step the same way. A node's NMT reset
leaves the shaft as it is.

Real time (``clock`` set: the emulator's own monotonic clock [s]): time is never
tied to frames. ``advance_to(t)`` steps whole periods up to ``t``, each ending
with every drive's own cycle (``on_period``); the emulator calls it often, and
every node on a SYNC calls it before latching, so a lost or late SYNC changes
only when feedback is latched. A SYNC also locks the periods' phase to itself, as
a CiA 402 drive synchronises its cycle to SYNC with a phase-locked loop: the shaft
is brought to the period boundary nearest the SYNC, which latches its state, and
the phase moves by a sixteenth of the SYNC's offset from that boundary (all of it
on the first SYNC, or the first after ``RELOCK`` periods without one). So the
periods keep to the SYNCs' grid: with SYNCs a period apart, jitter and all, the
physics advances one period per SYNC, as in lock-step, a late SYNC's missed
periods are made up once and no more, and a synchronous RPDO acts exactly one
period after the boundary of the SYNC its command answers, whatever the phases
of the emulator's and the host's clocks. A command
acts from the first period boundary at or after it is due. An emulator that falls
behind its clock simulates at most ``catch_up`` periods at once: the rest are
skipped (the plant holds still over them) and counted in ``skipped``, so the lock
its receive thread needs is never held for a backlog. Lock-step (no clock) keeps
its exact stepping per SYNC.

Loads (``Axis.load``) run in seconds since the first attached drive last entered
OPERATION ENABLED (``enabled``; in real time since the first SYNC after it, the run's
first), not since the clock's epoch; until its first enable (and after ``rest``) their
time stands at 0, so a load that steps in at 1.5 s steps in 1.5 s into the run, not onto
a disabled motor 1.5 s after the emulator started.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import Protocol

from plant_emulator.axes import Axis

__all__ = ["Shaft", "Timed", "run_period", "shafts_of"]

#: real time: a SYNC moves the periods' phase by this fraction of its offset from its boundary
PLL = 16
#: real time: a SYNC after this many periods without one locks the phase to itself at once
RELOCK = 10

#: a command taking effect ``offset`` [s] into the period: (offset, axis, mode, value SI,
#: computed one SYNC ago)
Timed = tuple[float, Axis, int, complex, bool]


def _offset(c: Timed) -> float:
    return c[0]


def run_period(
    advance: Callable[[float, float], None], timeline: list[Timed], t: float, period: float
) -> None:
    """Advance [t, t + period] by ``advance(h, t_start)``, applying each command at its offset.

    Commands at equal offsets are applied in the order given (a stable sort). The
    physics between two commands sees the earlier one held: ZOH, as a drive's
    modulator holds its reference.

    Parameters
    ----------
    advance : Callable[[float, float], None]
        Steps the physics by ``h`` [s] from time ``t_start`` [s].
    timeline : list[Timed]
        The commands of the period, each at its offset [s] into it.
    t : float
        [s] the period's start, as ``advance`` counts it.
    period : float
        [s] the period's length.
    """
    done = 0.0
    if timeline:
        if len(timeline) > 1:
            timeline = sorted(timeline, key=_offset)
        for offset, axis, mode, value, one_ago in timeline:
            advance(offset - done, t + done)
            axis.set_command(mode, value, computed_one_sync_ago=one_ago)
            done = offset
    advance(period - done, t + done)


def shafts_of(devices: Iterable[object]) -> list[Shaft]:
    """The shafts of ``devices``, each once: a drive's, each axis's of a drive of several
    (``plant_emulator.multi_axis``), an encoder's.

    Parameters
    ----------
    devices : Iterable[object]
        Emulated nodes.

    Returns
    -------
    list[Shaft]
        Their shafts, in the order met.
    """
    found: dict[int, Shaft] = {}
    for d in devices:
        for shaft in getattr(d, "shafts", None) or [getattr(d, "shaft", None)]:
            if shaft is not None:
                found.setdefault(id(shaft), shaft)
    return list(found.values())


class Coupled(Protocol):
    """A drive on a shaft: its commands for the period from ``t_start`` [s], and its own cycle."""

    def take_timeline(self, t_start: float) -> list[Timed]: ...

    def on_period(self) -> None: ...


class Shaft:
    """See the module docstring.

    ``sources`` are advanced before ``motion`` over each piece of a period, so the
    torque they apply over it is known when the motion integrates it.

    Parameters
    ----------
    motion : Axis
        The axis whose model integrates the motion.
    sources : Sequence[Axis]
        Torque sources coupled to it (a load machine).
    period : float
        [s] the SYNC period every period is advanced by.

    Raises
    ------
    ValueError
        If the period is not a finite number > 0.
    """

    def __init__(self, motion: Axis, *, sources: Sequence[Axis] = (), period: float) -> None:
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f"period must be > 0 s, got {period!r}")
        self.motion = motion
        self.sources = tuple(sources)
        self.axes = (*self.sources, motion)
        self.period = period
        #: True: time is the SYNC count times the period (lock-step across processes, where a
        #: frame's arrival time is scheduling noise); False: the SYNC's timestamp
        self.lockstep = False
        self.syncs = 0  #: SYNCs seen; the shaft has been advanced syncs - 1 periods
        self.t = 0.0  #: time of the latest SYNC [s] (real time: of the latest period boundary)
        #: real time: [s] from the latest period boundary to the latest SYNC, at which the nodes
        #: sample their synchronous TPDOs' data (CiA 301); lock-step: 0
        self.sync_offset = 0.0
        #: real time: the emulator's monotonic clock [s] (None: time steps with the SYNCs)
        self.clock: Callable[[], float] | None = None
        self.catch_up = 50  #: real time: the most periods advanced at once (the rest skipped)
        self.skipped = 0  #: real time: periods skipped behind the clock
        #: [s] loads run in t - load_origin; None: their time stands at 0 (no enable yet)
        self.load_origin: float | None = None
        self._origin_at_sync = False  #: real time: the next SYNC restarts the loads' time (``enabled``)
        self._synced_at: float | None = None  #: real time: [s] the clock at the latest SYNC
        self._drives: list[Coupled] = []
        self._seen: set[int] = set()
        self._stamp: float | None = None
        self._step = motion.advance if not self.sources else self._step_all

    def rest(self) -> None:
        """The plant back to its initial state: every axis at rest at angle zero with its
        controller state cleared, the loads' time at 0 until the next enable (an emulator control
        between runs, ``rig emulate``'s SIGUSR1; no CANopen command does this, as none moves a
        real shaft)."""
        for axis in self.axes:
            axis.reset()
        self.load_origin = None

    def attach(self, drive: Coupled) -> None:
        """Take ``drive``'s commands into every period from now on.

        Parameters
        ----------
        drive : Coupled
            A drive on this shaft.
        """
        self._drives.append(drive)

    @property
    def position(self) -> float:
        """Shaft angle [rad]."""
        return self.motion.position

    @property
    def velocity(self) -> float:
        """Shaft speed [rad/s]."""
        return self.motion.velocity

    def sync(self, node: object, timestamp: float) -> bool:
        """``node`` handles a SYNC stamped ``timestamp`` [s]: the shaft is brought to it.

        A SYNC is new when its timestamp differs from the latest one's, or when ``node``
        has handled the latest one already; a new SYNC advances the period ending at it
        (none before the first).

        Parameters
        ----------
        node : object
            The node handling it.
        timestamp : float
            [s] the SYNC's receive time.

        Returns
        -------
        bool
            True when this call advanced the shaft (lock-step).
        """
        key = id(node)
        if timestamp == self._stamp and key not in self._seen:
            self._seen.add(key)  # another node of the shaft handles the same SYNC: nothing more
            return False
        self._seen = {key}
        self._stamp = timestamp
        if self.clock is not None:
            self._lock(self.clock())
            return False
        self.syncs += 1
        now = self.syncs * self.period if self.lockstep else timestamp
        if self.syncs > 1:
            self._advance(self.t)
        self.t = now
        return True

    def _lock(self, now: float) -> None:
        """Real time: a SYNC at ``now`` [s] (the module docstring). The shaft is brought to the
        period boundary nearest the SYNC, then the periods' phase moves toward the SYNC: all the
        way on the first SYNC, or the first after ``RELOCK`` periods without one; by ``1/PLL`` of
        the SYNC's offset from its boundary otherwise, so the count of periods keeps to the
        SYNCs' grid however they jitter (docs/emulator.md says what moving it all the way did)."""
        period = self.period
        relock = self._synced_at is None or now - self._synced_at > RELOCK * period
        self._synced_at = now
        self.advance_to(now)
        ends = now - self.t >= 0.5 * period  # the nearest period boundary is the one after the SYNC
        if ends:
            self._advance(self.t)
            self.t += period
        self.t += now - self.t if relock else (now - self.t) / PLL
        if ends:  # the drives' cycles at the period's end, the phase moved
            for drive in self._drives:
                drive.on_period()
        self.sync_offset = 0.0
        if self._origin_at_sync:  # the run's first SYNC since the enable (``enabled``)
            self._origin_at_sync = False
            self.load_origin = self.t - period

    def advance_to(self, t: float, *, ahead: float = 0.0) -> int:
        """Real time: advance whole periods up to ``t`` [s]; each ends with every drive's cycle.
        At most ``catch_up`` of them: the earlier ones are skipped (``skipped``). With ``ahead``
        [s], a period that ends within ``ahead`` after ``t`` is advanced now too: the state at
        the next SYNC prepared before it comes (``WorldClock.prepare``). A period's commands are
        those due by its start (``take_timeline``), all known by then, so the state is the
        one computed at the SYNC.

        Parameters
        ----------
        t : float
            [s] the clock's time to advance to.
        ahead : float
            [s] how far past ``t`` a period may end and still be advanced now.

        Returns
        -------
        int
            The number of periods advanced.
        """
        behind = int((t - self.t) / self.period + 1e-9)
        if behind > self.catch_up:
            skip = behind - self.catch_up
            self.t += skip * self.period
            self.skipped += skip
        n = 0
        while self.t + self.period <= t + ahead + 1e-12:
            self._advance(self.t)
            for drive in self._drives:  # its cycle sees the period's start, as at a SYNC (``sync``):
                drive.on_period()  # what it queues is due at the next period's start either way
            self.t += self.period
            n += 1
        return n

    def enabled(self, drive: Coupled) -> None:
        """``drive`` entered OPERATION ENABLED: the first drive's enable restarts the loads' time.
        In real time it restarts again at the next SYNC, the run's first (a host sends none between
        its enable and its first cycle, which a real-time host reaches tens of ms later), so the
        loads' time there is one period, as at lock-step's first SYNC, which ends the world's
        first period.

        Parameters
        ----------
        drive : Coupled
            The drive that was enabled.
        """
        if self._drives and drive is self._drives[0]:
            self.load_origin = self.t
            self._origin_at_sync = self.clock is not None

    def _advance(self, t: float, length: float | None = None) -> None:
        """The period from ``t`` [s] (of ``length`` [s], default the period)."""
        drives = self._drives
        if len(drives) == 1:
            timeline = drives[0].take_timeline(t)
        else:
            timeline = [c for d in drives for c in d.take_timeline(t)]
        origin = self.load_origin
        h = self.period if length is None else length
        run_period(self._step, timeline, 0.0 if origin is None else t - origin, h)

    def _step_all(self, h: float, t: float) -> None:
        for axis in self.axes:
            axis.advance(h, t)
