"""Interpolated position mode (CiA 402 mode 7, ip) of an emulated drive: its input buffer and its
linear interpolator.

The objects (CiA 402-2; axis n's 0x800 (n - 1) higher):

- 0x60C0 interpolation sub-mode select: 0, linear interpolation, the only one this drive has
  (another value: SDO abort 0x06090030);
- 0x60C1 interpolation data record, sub 1 its one entry: a position set-point (INTEGER32,
  position units, absolute);
- 0x60C2 interpolation time period, value x 10^index s: the time between two records, a whole
  number of the drive's periods (at least one); written only while ip mode is inactive (abort
  0x08000022 while it is active);
- 0x60C3 interpolation sync definition: sub 1 synchronize on group, 0 (the general SYNC, read
  only), sub 2 ip sync every n event: 1, an interpolation cycle every SYNC (another value:
  0x06090030);
- 0x60C4 interpolation data configuration: sub 1 maximum buffer size (ro), sub 2 actual buffer
  size (1 .. sub 1: the FIFO's depth; a new size empties it), sub 3 buffer organisation (0 FIFO;
  1, a ring, is refused: this drive has a FIFO), sub 4 buffer position (CiA 402: the next free
  entry; in a FIFO the records waiting, a write to it has no effect), sub 5 size of data record
  (4 bytes only), sub 6 buffer clear (0: the buffer is emptied and its access disabled, 1: its
  access enabled again).

What the drive does with its buffer, a FIFO:

- A record written to 0x60C1:01, by SDO or in an RPDO, in OPERATION ENABLED in mode 7 with the
  buffer's access enabled, is appended. One that finds the FIFO full (sub 2 records), the access
  disabled, or the drive in another state or mode, is refused: an SDO write by abort 0x08000022
  (the present device state), a record in an RPDO (which cannot be refused) dropped; one the
  buffer refused (full, or its access disabled) is counted (``refused``) and logged. Leaving
  OPERATION ENABLED (a stop, a fault, a disable) or mode 7 empties the FIFO: an interrupted
  profile never resumes (the RPDOs of a host's stop, which carry its last record on, are not
  taken).
- Controlword bit 4 (enable ip mode) set in OPERATION ENABLED in mode 7: ip mode active
  (statusword bit 12). Each interpolation cycle (0x60C2, whole periods of the drive from the
  first take; the first after bit 4 rose) the drive takes the oldest record: its position demand
  moves from where it is to the record, linearly, one step per period of its own cycle (sub-mode
  0), for the position loop to follow. With bit 4 clear the demand holds and records wait in the
  FIFO.
- Underflow: an interpolation cycle that finds the FIFO empty waits: a record that comes while
  it waits (within the same SYNC: a synchronous RPDO's data are applied at the SYNC, after the
  drive's cycle there; or the record of the RPDO whose controlword set bit 4 with the FIFO empty)
  is taken at once, so a host that sends one set-point per SYNC is followed one period later, as
  in CSP. An interpolation cycle that passes with none holds the demand at
  the last record (the motor stops there under its position loop), counts an underflow
  (``underflows``) and sets statusword bit 7 (warning) until the next record is taken.
- Statusword bit 10 (target reached): the FIFO empty, the last segment done and the motor within
  the position window 0x6067 (0.01 rad where the drive has none) of the demand.
"""

from __future__ import annotations

import collections
import logging
import math
from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from drivers.maps.cia import SdoAbortCode

__all__ = ["IP_OBJECTS", "Interpolation"]

log = logging.getLogger(__name__)

SUBMODE, RECORD, TIME, SYNC_DEFINITION, CONFIG = (
    cia.INTERPOLATION_SUBMODE,
    cia.INTERPOLATION_DATA,
    cia.INTERPOLATION_PERIOD,
    cia.INTERPOLATION_SYNC,
    cia.INTERPOLATION_CONFIG,
)
IP_OBJECTS = frozenset({SUBMODE, RECORD, TIME, SYNC_DEFINITION, CONFIG})  #: the objects whose writes it takes
MAX_SIZE, SIZE, ORGANISATION, POSITION, RECORD_SIZE, CLEAR = 1, 2, 3, 4, 5, 6  #: 0x60C4's subs
ENABLE_IP = 1 << 4  #: controlword bit 4
ACTIVE, TARGET_REACHED, WARNING = 1 << 12, 1 << 10, 1 << 7  #: statusword bits


class Interpolation:
    """One drive's ip mode (see the module docstring) over its objects ``od`` (``has``: the
    drive has the object); ``to_si`` turns a record [position units] into rad.

    Parameters
    ----------
    od : Any
        The drive's object store.
    has : Callable[[int], bool]
        Whether the drive has an object (index).
    to_si : Callable[[float], float]
        A record [position units] -> [rad].
    """

    def __init__(self, od: Any, has: Callable[[int], bool], to_si: Callable[[float], float]) -> None:
        self.od, self.has, self.to_si = od, has, to_si
        self.period = 0.0  #: [s] the drive's cycle (``cycle``'s; 0 before the first)
        self.fifo: collections.deque[int] = collections.deque()  #: the records [position units]
        self.access = True  #: 0x60C4:06: the buffer takes records
        self.in_mode = False  #: OPERATION ENABLED in mode 7
        self.bit4 = False  #: controlword bit 4, enable ip mode
        self.demand = math.nan  #: [rad] the position demand
        self._from = self._to = math.nan  #: [rad] the segment under way
        self._step = self._steps = 0
        self.waiting = False  #: the last interpolation cycle found the FIFO empty
        self.starved = False  #: an interpolation cycle passed without a record (bit 7)
        self.refused = 0  #: records the buffer refused (full, or its access disabled)
        self.underflows = 0  #: interpolation cycles that passed without a record
        self.status = 0  #: statusword bits 7, 10, 12 of the last cycle

    @property
    def active(self) -> bool:
        """ip mode active (statusword bit 12)."""
        return self.in_mode and self.bit4

    @property
    def size(self) -> int:
        """The FIFO's depth (0x60C4:02; 1 where the drive has no 0x60C4)."""
        return int(self.od.read(CONFIG, SIZE)) if self.has(CONFIG) else 1

    # --- writes (SDO or RPDO) ------------------------------------------------------------------
    def write(self, index: int, subindex: int, data: bytes, *, rpdo: bool) -> float | None:
        """A write to one of ``IP_OBJECTS`` about to be stored (SdoAbortedError refuses it); the
        new demand [rad] where a record was taken at once (the interpolator waited), else None.

        Parameters
        ----------
        index, subindex : int
            The object written (one of ``IP_OBJECTS``).
        data : bytes
            The bytes to store.
        rpdo : bool
            Written by an RPDO (else by SDO).

        Returns
        -------
        float | None
            [rad] the new demand where a record was taken at once; else None.

        Raises
        ------
        SdoAbortedError
            If the write is refused (the abort code says why).
        """
        if index == SUBMODE:
            if int.from_bytes(data, "little", signed=True) != 0:
                raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)  # linear interpolation only
        elif index == RECORD and subindex == 1:
            return self._record(int.from_bytes(data, "little", signed=True), rpdo=rpdo)
        elif index == TIME and self.active:  # the period of a profile under way stands
            raise SdoAbortedError(SdoAbortCode.DEVICE_STATE)
        elif index == SYNC_DEFINITION and subindex == 2 and int.from_bytes(data, "little") != 1:
            raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)  # an interpolation cycle every SYNC
        elif index == CONFIG:
            self._configure(subindex, int.from_bytes(data, "little"))
        return None

    def _record(self, raw: int, *, rpdo: bool) -> float | None:
        if not self.in_mode:  # a stop's RPDOs carry the last record on: not the buffer's
            if not rpdo:
                raise SdoAbortedError(SdoAbortCode.DEVICE_STATE)
            return None
        why = ""
        if not self.access:
            why = "the buffer's access is disabled (0x60C4:06 = 0)"
        elif self.waiting and self.active and not self.fifo:
            self._begin(raw)
            return self.demand
        elif len(self.fifo) >= self.size:
            why = f"the buffer is full ({self.size} records)"
        if why:
            self.refused += 1
            log.warning("ip record %d refused%s: %s", raw, " (RPDO: dropped)" if rpdo else "", why)
            if not rpdo:
                raise SdoAbortedError(SdoAbortCode.DEVICE_STATE)
            return None
        self.fifo.append(raw)
        self.show()
        return None

    def _configure(self, subindex: int, value: int) -> None:
        if subindex == SIZE:
            if not 1 <= value <= int(self.od.read(CONFIG, MAX_SIZE)):
                raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
            self.clear()  # a new depth starts empty
        elif subindex == ORGANISATION and value != 0:  # 1 is a ring: this drive has a FIFO
            raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
        elif subindex == RECORD_SIZE and value != 4:  # one INTEGER32 position
            raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
        elif subindex == CLEAR:
            if value not in (0, 1):
                raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
            if not value:
                self.clear()
            self.access = bool(value)

    def controlword(self, cw: int) -> None:
        """Bit 4 of a controlword written (SDO or RPDO); its rise in ip mode starts the
        interpolation (``_activate``).

        Parameters
        ----------
        cw : int
            The controlword written.
        """
        was, self.bit4 = self.active, bool(cw & ENABLE_IP)
        if self.active and not was:
            self._activate()

    def _activate(self) -> None:
        """ip mode became active: the oldest record is taken at the next interpolation cycle; where
        none waits, the interpolator waits now, and takes the first to come at once (the record
        of the RPDO that set bit 4)."""
        self.waiting = not self.fifo
        self.starved = False

    # --- the drive's state and cycle -----------------------------------------------------------
    def track(self, in_mode: bool) -> None:
        """The drive is (or is no longer) OPERATION ENABLED in mode 7: leaving empties the FIFO
        and holds the interpolator; entering with bit 4 set activates it (its FIFO is empty).

        Parameters
        ----------
        in_mode : bool
            OPERATION ENABLED in mode 7.
        """
        was = self.active
        if self.in_mode and not in_mode:
            self.clear()
            self.waiting = self.starved = False
            self._step = self._steps = 0
        self.in_mode = in_mode
        if self.active and not was:
            self._activate()

    def clear(self) -> None:
        """Empty the FIFO (0x60C4:04 shows it)."""
        self.fifo.clear()
        self.show()

    def start(self, position: float) -> None:
        """Entering ip mode enabled: the demand starts where the motor is [rad].

        Parameters
        ----------
        position : float
            [rad] where the motor is.
        """
        self.demand = position
        self._step = self._steps = 0
        self.waiting = self.starved = False

    def cycle(self, h: float, position: float) -> float:
        """One period (``h`` [s]) of the drive in ip mode, enabled, the motor at ``position``
        [rad]: the position demand [rad]; ``status`` its statusword bits.

        Parameters
        ----------
        h : float
            [s] the period.
        position : float
            [rad] where the motor is.

        Returns
        -------
        float
            [rad] the position demand.
        """
        self.period = h
        if math.isnan(self.demand):
            self.start(position)
        if self.active:
            if self._step < self._steps:
                self._step += 1
                self.demand = self._from + (self._to - self._from) * self._step / self._steps
            else:  # an interpolation cycle: the next record
                if self.waiting:
                    self.underflows += 1
                    self.starved = True
                if self.fifo:
                    self._begin(self.fifo.popleft())
                    self.show()
                else:
                    self.waiting = True
        done = not self.fifo and self._step >= self._steps
        window = self._window()
        reached = done and abs(position - self.demand) <= window
        self.status = (ACTIVE if self.active else 0) | (TARGET_REACHED if reached else 0)
        self.status |= WARNING if self.starved and self.active else 0
        return self.demand

    def _begin(self, raw: int) -> None:
        """A record taken: the segment from the demand to it, over the interpolation period."""
        self._from, self._to = self.demand, self.to_si(raw)
        self._steps = self._periods()
        self._step = 1
        self.demand = self._from + (self._to - self._from) / self._steps
        self.waiting = self.starved = False

    def _periods(self) -> int:
        """The interpolation period (0x60C2) in whole periods of the drive, at least one."""
        if not self.has(TIME) or not self.period > 0.0:
            return 1
        seconds = int(self.od.read(TIME, 1)) * 10.0 ** int(self.od.read(TIME, 2))
        return max(1, round(seconds / self.period))

    def _window(self) -> float:
        """[rad] the position window 0x6067, or 0.01 rad."""
        if not self.has(cia.POSITION_WINDOW):
            return 0.01
        return abs(self.to_si(int(self.od.read(cia.POSITION_WINDOW, 0))) - self.to_si(0))

    def show(self) -> None:
        """0x60C4:04, the records waiting (after any write to 0x60C4: one to sub 4 has no effect)."""
        if self.has(CONFIG):
            self.od.write(CONFIG, POSITION, len(self.fifo))
