"""The drive's own watch of the host, a part of ``drivers.cia402.Cia402Axis``.

``DriveSupervision`` makes a CiA 402 drive stop itself when the host dies, and tells it the cycle,
where it can: its heartbeat consumer 0x1016 watches the host, 0x6007 says how it reacts, its
producer 0x1017 beats for the host's own watch, in the cyclic synchronous modes 0x60C2 / 0x1006
give the SYNC period, and on the toolkit's own drive the command RPDO's event timer is a deadline
on the host's commands. ``enable`` sets the watches, a confirmed ``disable`` lifts them. Each
setting is optional: an entry the drive declares read-only is read, not written, and a refusal is
one warning (``drivers.cia402_access.Setting``). The part owns its state; what it needs of its
axis is ``SupervisedAxis``.
"""

from __future__ import annotations

import logging
import math
from typing import Any, Protocol

from drivers.cia402_access import interpolation_period as interpolation_setting
from drivers.cia402_access import period_text
from drivers.cia402_discovery import Cia402Discovery
from drivers.cia402_pdo import variable
from drivers.cia402_process import ProcessData
from drivers.cia402_setup import Cia402Setup
from drivers.errors import RigError
from drivers.maps import cia
from drivers.maps.cia import Mode

__all__ = ["DriveSupervision"]

log = logging.getLogger(__name__)

#: the modes whose drive is told the SYNC period (0x60C2, 0x1006)
_CYCLIC = (Mode.CSP, Mode.INTERPOLATED_POSITION, Mode.CSV, Mode.CST)


class SupervisedAxis(Protocol):
    """What the supervision needs of its axis: the dictionary, the SDO access, the mode and the
    process data in force (``drivers.cia402.Cia402Axis``)."""

    node: Any
    op_mode: Mode
    data: ProcessData | None
    heartbeat_timeout: float  #: [s] the host's watch of the drive's heartbeat (0: none)
    period: float  #: [s] the SYNC period (0x60C2, 0x1006); 0: not told
    discovery: Cia402Discovery  #: what the drive is (``optional``: an object it may lack)
    settings: Cia402Setup  #: its settings (``setting``: an entry written where writable)

    @property
    def where(self) -> str:
        """``node 5`` (and the axis on a drive of several), for messages."""

    @property
    def toolkit_drive(self) -> bool:
        """The toolkit's own drive, identified by its 0x1018."""

    def sdo_read(self, index: int, subindex: int = 0) -> Any:
        """An object's value, read by SDO."""

    def sdo_write(self, index: int, subindex: int, value: Any) -> None:
        """An SDO download."""

    def sibling_watches(self) -> list[DriveSupervision]:
        """The supervision of the other drive axes on the node."""


class DriveSupervision:
    """The drive's watch of the host, of its commands, and its knowledge of the cycle.

    Parameters
    ----------
    axis : SupervisedAxis
        The axis it supervises.
    host : tuple of (int, float) or None
        (host node id, time [s]) the drive's heartbeat consumer watches; None: none.
    abort_connection : int or None
        0x6007, the drive's reaction to a lost host (None: the drive's own).
    rpdo_deadline : float
        [s] without the command RPDO before the toolkit's drive stops itself (0: none).
    """

    def __init__(
        self,
        axis: SupervisedAxis,
        host: tuple[int, float] | None,
        abort_connection: int | None,
        rpdo_deadline: float,
    ) -> None:
        self.axis = axis
        self.host = host
        self.abort_connection = abort_connection
        self.rpdo_deadline = rpdo_deadline
        self.consumer_sub: int | None = None  #: the drive's 0x1016 entry that watches the host
        self.deadline_comm: int | None = None  #: the RPDO whose event timer is the deadline

    def configure(self) -> None:
        """At set-up: the heartbeat consumer watches the host, 0x6007, 0x1017, and the period."""
        axis, od = self.axis, self.axis.node.object_dictionary
        if self.host is not None and cia.CONSUMER_HEARTBEAT in od:
            self.consumer_sub = self._watch_host(*self.host)
        elif self.host is not None:
            log.warning(
                "%s: the drive has no heartbeat consumer (0x1016): it cannot watch the host's heartbeat "
                "and will not stop itself if the host dies; give it another stop (a safety circuit)",
                axis.where,
            )
        if self.abort_connection is not None and cia.ABORT_CONNECTION_OPTION in od:
            why = "the reaction to a lost host"
            self.axis.settings.setting(cia.ABORT_CONNECTION_OPTION, 0, self.abort_connection, why)
        if axis.heartbeat_timeout > 0.0 and cia.PRODUCER_HEARTBEAT in od:
            beat = max(1, round(axis.heartbeat_timeout / 3 * 1000))  # ms
            self.axis.settings.setting(
                cia.PRODUCER_HEARTBEAT, 0, beat, "the drive's heartbeat the host watches"
            )
        if axis.period > 0.0 and axis.op_mode in _CYCLIC:
            if variable(od, (cia.INTERPOLATION_PERIOD, 1)) is not None:
                self._interpolation_period()
            if cia.COMM_CYCLE_PERIOD in od:
                axis.settings.setting(
                    cia.COMM_CYCLE_PERIOD, 0, round(axis.period * 1e6), "the SYNC period [us]"
                )

    def _interpolation_period(self) -> None:
        """0x60C2 = the SYNC period, in the drive's own exponent (sub 2) where it can be given in
        it; a warning naming the period in force where it cannot."""
        od = self.axis.node.object_dictionary
        sub2 = variable(od, (cia.INTERPOLATION_PERIOD, 2))
        readable = sub2 is not None and sub2.readable
        exponent = self.axis.discovery.optional(cia.INTERPOLATION_PERIOD, 2) if readable else None
        writable = sub2 is not None and sub2.writable
        value, new_exponent, in_force = interpolation_setting(
            self.axis.period, None if exponent is None else int(exponent), writable
        )
        why = f"the SYNC period {period_text(self.axis.period)}"
        if new_exponent is not None and not self.axis.settings.setting(
            cia.INTERPOLATION_PERIOD, 2, new_exponent, why
        ):
            return
        if not self.axis.settings.setting(cia.INTERPOLATION_PERIOD, 1, value, why):
            return
        if abs(in_force - self.axis.period) > 1e-9 * self.axis.period:
            log.warning(
                "%s: the SYNC period %s cannot be given in the drive's interpolation time index "
                "(0x60C2:02 = %s, %s in the EDS): 0x60C2 = %d x 10^%s s, the drive interpolates over %s",
                self.axis.where,
                period_text(self.axis.period),
                exponent,
                getattr(sub2, "access_type", "?"),
                value,
                exponent,
                period_text(in_force),
            )

    def _watch_host(self, host_node: int, timeout: float) -> int | None:
        """Put (host, timeout) in the consumer entry that has the host, or a free one; its sub."""
        read = self.axis.sdo_read
        count = int(read(cia.CONSUMER_HEARTBEAT, 0))
        entries = {s: int(read(cia.CONSUMER_HEARTBEAT, s)) for s in range(1, count + 1)}
        sub = next((s for s, e in entries.items() if (e >> 16) & 0xFF == host_node), None)
        sub = sub or next((s for s, e in entries.items() if not e & 0xFFFF or not (e >> 16) & 0xFF), None)
        if sub is None:
            taken = ", ".join(
                f"0x1016:{s:02X} node {(e >> 16) & 0xFF} ({e & 0xFFFF} ms)" for s, e in entries.items()
            )
            log.warning(
                "%s: no free heartbeat consumer entry (%s): the drive does not watch the host and will not "
                "stop itself if it dies; where that watch is not needed, free its entry (rig drive sdo write "
                "0x1016:NN 0)",
                self.axis.where,
                taken or "0x1016 has none",
            )
            return None
        entry = host_node << 16 | max(1, min(0xFFFF, round(timeout * 1000)))
        if entries[sub] == entry:
            return sub
        why = "the drive's watch of the host's heartbeat"
        if entries[sub] and not self.axis.settings.setting(cia.CONSUMER_HEARTBEAT, sub, 0, why):
            return None
        return sub if self.axis.settings.setting(cia.CONSUMER_HEARTBEAT, sub, entry, why) else None

    def watch(self) -> None:
        """At each enable: the host's watch again where a confirmed disable lifted it, and the
        deadline of the commands (``watch_commands``)."""
        axis = self.axis
        if self.host is not None and self.consumer_sub is None and axis.data is not None:
            if cia.CONSUMER_HEARTBEAT in axis.node.object_dictionary:
                self.consumer_sub = self._watch_host(*self.host)
        self.watch_commands()

    def watch_commands(self) -> None:
        """The toolkit's own drive: the deadline of its command RPDO, that RPDO's event timer
        (CiA 301 0x1400+n sub 5, which on an RPDO is its deadline: no RPDO within it, EMCY 0x8250
        and the drive's reaction 0x6007) at ``rpdo_deadline`` [s], rounded up to whole ms, so
        that a host that stops sending (dead, frozen) has the drive stop itself within a few
        periods, not at its heartbeat's 0.3 s. A confirmed disable lifts it (``unwatch``)."""
        data = self.axis.data
        rpdo = data.rpdo if data is not None else None
        if not (self.rpdo_deadline > 0.0 and rpdo is not None and self.axis.toolkit_drive):
            return
        ms = max(1, math.ceil(self.rpdo_deadline * 1000.0 - 1e-9))
        if self.axis.settings.setting(
            rpdo.comm, cia.PDO_COMM_EVENT_TIMER, ms, "the deadline of the commands [ms]"
        ):
            self.deadline_comm = rpdo.comm

    def unwatch(self) -> None:
        """Disabled on purpose, and confirmed: the drive stops watching the host and its commands
        (``unwatch_host``, ``unwatch_commands``)."""
        self.unwatch_host()
        self.unwatch_commands()

    def unwatch_host(self) -> None:
        """The drive stops watching the host (whose heartbeat ends with the run; a disabled drive
        needs no watch); an entry not cleared stays the axis's (a warning). On a drive of several
        axes the entry is the node's: the last of its axes to be disabled clears it, never one
        while another may still be enabled."""
        sub = self.consumer_sub
        if sub is not None and any(w.consumer_sub == sub for w in self.axis.sibling_watches()):
            self.consumer_sub = None  # another axis of the node still holds the watch
            return
        if sub is not None:
            try:
                self.axis.sdo_write(cia.CONSUMER_HEARTBEAT, sub, 0)
            except RigError as exc:
                log.warning("%s: heartbeat consumer entry not cleared: %s", self.axis.where, exc)
                return
            self.consumer_sub = None

    def unwatch_commands(self) -> None:
        """The drive's deadline on the commands is lifted; one not lifted stays the axis's (a
        warning: the stop's RPDOs go on meanwhile)."""
        comm = self.deadline_comm
        if comm is not None:
            try:
                self.axis.sdo_write(comm, cia.PDO_COMM_EVENT_TIMER, 0)
            except RigError as exc:
                where = self.axis.where
                log.warning("%s: the commands' deadline (0x%04X:05) not lifted: %s", where, comm, exc)
                return
            self.deadline_comm = None

    def kept(self) -> str:
        """What the drive still watches, in words, after a disable not confirmed.

        Returns
        -------
        str
            Its heartbeat consumer and its deadline on the commands, where set.
        """
        kept = [f"its heartbeat consumer 0x1016:{self.consumer_sub:02X}"] if self.consumer_sub else []
        if self.deadline_comm is not None:
            kept.append(f"its deadline on the commands 0x{self.deadline_comm:04X}:05")
        if not kept:
            return "the drive may still be enabled"
        return f"{' and '.join(kept)} left in place: the drive stops itself when the host goes quiet"
