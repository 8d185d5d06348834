"""The cycle of a CiA 402 drive on the host: its feedback from the TPDOs, its supervision, its
command RPDO.

``Cia402Cycle`` is the part of ``drivers.cia402.Cia402Axis`` that runs every period, once set-up
(its part ``drivers.cia402_mapping``) has found the mapping in force (``data``:
``drivers.cia402_process``): ``feedback`` reads the last TPDOs in SI through the plan made once
for the mapping (``drivers.cia402_plan.CyclePlan``), ``shaft_speed`` the speed 0x606C,
``supervise`` checks the statusword and, where mapped, 0x6061 (a drive that leaves OPERATION
ENABLED or changes its mode stops the run, named), ``command`` packs and sends the RPDO of the
mode's target with the controlword.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import canopen

from drivers.base import Feedback
from drivers.canopen_axis import CanopenAxis, TpdoSlot, sample_interval
from drivers.cia402_plan import CW, DQ_RX, POSITION, VELOCITY, CyclePlan
from drivers.cia402_process import ProcessData
from drivers.cia402_states import PowerStates, power_state
from drivers.cia402_units import DriveUnits
from drivers.errors import CommunicationError, RigError, SafetyStop, brief
from drivers.maps import cia
from drivers.maps.cia import Mode, PowerState
from drivers.producer_watch import travel_band

__all__ = ["Cia402Cycle", "power_state"]  # power_state: drivers.cia402_states's

log = logging.getLogger(__name__)

_ENABLED_MASK, _ENABLED_BITS = PowerState.OPERATION_ENABLED.mask, PowerState.OPERATION_ENABLED.bits


def _object(index: int, subindex: int) -> str:
    return f"0x{index:04X}" + (f":{subindex:02X}" if subindex else "")


class Cia402Cycle(CanopenAxis):
    """The cycle of ``Cia402Axis`` (see the module docstring) on its CANopen node: it owns what each
    cycle reads and writes, which set-up fills (``data``, ``units``, ``measures``, the plan).

    Parameters
    ----------
    name : str
        The axis's name.
    mode : str
        Its mode's name.
    network : canopen.Network
        The network of its node.
    node_id : int
        Its node id.
    op_mode : Mode
        Its mode's code.
    maps : frozenset of str
        What the TPDOs carry (``drivers.cia402_feedback``).
    period : float
        [s] the SYNC period, 0: not told.
    states : PowerStates
        The drive's state machine (``drivers.cia402_states``), whose stop the RPDO carries.
    **access : Any
        ``CanopenAxis``'s keywords (the EDS, heartbeat, SDO time-out ...).
    """

    def __init__(
        self,
        name: str,
        mode: str,
        network: canopen.Network,
        node_id: int,
        *,
        op_mode: Mode,
        maps: frozenset[str],
        period: float,
        states: PowerStates,
        **access: Any,
    ) -> None:
        super().__init__(name, mode, network, node_id, **access)
        self.op_mode, self.maps, self.states = op_mode, maps, states
        self.period = period  #: [s] the SYNC period (0x60C2, 0x1006), 0: not told
        self.units = DriveUnits(math.nan, math.nan, math.nan, math.nan, {})  #: set-up's
        self.data: ProcessData | None = None  #: the process data in force (set-up)
        self.measures: frozenset[str] = frozenset()
        self.max_acceleration = math.inf  #: [rad/s^2] 0x60C5/0x60C6, read at set-up (inf: none said)
        self._plan = CyclePlan(None, frozenset(), None)  #: none until set-up maps the process data
        self._motion: TpdoSlot | None = None  #: the slot whose stamp is the sample's (set-up)
        self._turns = 0
        self._angle: float | None = None
        #: the velocity by difference (no 0x606C mapped): the last sample's (stamp, position, velocity)
        self._moved: tuple[float | None, float, float] = (None, math.nan, 0.0)
        self._target_raw: int | None = None  #: the target of the last command, in the drive's units
        self._speed_misses = 0  #: calls of ``shaft_speed`` since the last new velocity TPDO

    def feedback(self) -> Feedback:
        """The last TPDOs in SI (the frame angle unwrapped in mode -2).

        Returns
        -------
        Feedback
            Position [rad], velocity [rad/s], torque [N m], current [A] and the sample's stamp.
        """
        data, u = self.data, self.units
        assert data is not None
        if self.op_mode == Mode.DQ_VOLTAGE:
            return self._dq_feedback(data)
        stamp = self._motion.timestamp if self._motion is not None else time.monotonic()
        plan = self._plan
        values = plan.feedback()
        p, v = plan.position, plan.velocity
        position = values[0] / u.position if p else math.nan
        return Feedback(
            position,
            values[p] / u.velocity if v else self._difference(position, stamp),
            values[p + v] / 1000.0 * u.rated_torque if plan.torque else math.nan,
            values[p + v + plan.torque] / 1000.0 * u.rated_current if plan.current else math.nan,
            stamp,
        )

    def quanta(self) -> tuple[float, float]:
        return self.units.quanta()  # 0x608F/0x60A8, 0x60A9 or [axis.units]

    def shaft_speed(self) -> float | None:
        """0x606C [rad/s]: the TPDO's where a new one came since the last call, else read by SDO
        (a drive whose TPDOs stopped, as after an NMT reset).

        Returns
        -------
        float or None
            [rad/s]; None where neither has it now.
        """
        slot = self.data.slot_of(VELOCITY) if self.data is not None else None
        if slot is not None and slot.timestamp is not None:
            if slot.timestamp != self._speed_stamp:
                self._speed_stamp, self._speed_misses = slot.timestamp, 0
                return float(self.data.value(VELOCITY)) / self.units.velocity  # type: ignore[union-attr]
            self._speed_misses += 1
            if self._speed_misses < 3:  # a TPDO late: the next one
                return None
        try:
            return float(self.sdo_read(cia.VELOCITY_ACTUAL)) / self.units.velocity
        except RigError as exc:
            log.debug("%s: no speed: %s", self.where, exc)
            return None

    def _difference(self, position: float, stamp: float | None) -> float:
        """[rad/s] the backward difference of ``position`` (the sample stamped ``stamp``) from the
        sample before; the same again for the same sample; 0 at the first."""
        last, before, speed = self._moved
        if stamp is not None and stamp == last:
            return speed
        if last is not None and stamp is not None:
            dt = sample_interval(last, stamp, self.period)
            speed = (position - before) / dt if dt > 0.0 else speed
        self._moved = (stamp, position, speed)
        return speed

    def foreign_sample(self, before: Feedback, after: Feedback) -> str | None:
        """A position that contradicts the drive's own speed 0x606C (``travel_band``) from one
        sample to the next (one SYNC apart): another producer's frame, named with the COB-ID that
        carried the odd value (the position's, or the speed's where the position agrees with the
        speed before). The elapsed time is the period where the stamps are on its grid (lock-step),
        else anything from 0 (a burst after a stall) to the stamps' difference or the period,
        whichever longer, and two periods more. Not checked without 0x606C mapped, nor in dq, nor
        on a drive that declares no acceleration limit (``max_acceleration``).

        Parameters
        ----------
        before, after : Feedback
            Two samples one SYNC apart.

        Returns
        -------
        str or None
            The other producer, named; None where the samples agree.
        """
        data = self.data
        if data is None or self.op_mode == Mode.DQ_VOLTAGE or "velocity" not in self.maps:
            return None
        s1, s2 = before.stamp, after.stamp
        if s1 is None or s2 is None or s2 == s1:
            return None
        resolution, accel = self.quanta(), self.max_acceleration
        period = self.period
        dt_lo = dt_hi = period
        if abs(s2 - s1 - period) > 1e-6 * period:  # receive times, not the SYNC grid
            dt_lo, dt_hi = 0.0, max(period, s2 - s1) + 2.0 * period
        v1, v2 = before.velocity, after.velocity
        travel = after.position - before.position
        band = travel_band(v1, v2, dt_lo, dt_hi, resolution=resolution, accel=accel)
        if band is None or band[0] <= travel <= band[1]:
            return None
        lo, hi = band
        position, speed = data.slot_of(POSITION), data.slot_of(VELOCITY)
        odd = position
        if speed is not None and speed is not position:
            lo1, hi1 = travel_band(v1, v1, dt_lo, dt_hi, resolution=resolution, accel=accel) or band
            odd = speed if lo1 <= travel <= hi1 else position  # the position agrees with the speed before
        where = f"COB-ID 0x{odd.cob_id:03X} (a TPDO of node {self.node_id})" if odd is not None else "a TPDO"
        return (
            f"node {self.node_id}: another producer on {where}: the position moved {travel:.4g} rad in one "
            f"period where the drive's own speed (0x606C: {v1:.4g}, then {v2:.4g} rad/s) and acceleration "
            f"(at most {accel:.4g} rad/s^2) allow {lo:.4g} to {hi:.4g} rad"
        )

    def cycle_frames(self) -> list[tuple[str, int]]:
        """The TPDOs and the RPDO in force, each named with the objects it maps.

        Returns
        -------
        list of (str, int)
            (what the frame is, its data bytes) for each frame of a cycle.
        """
        data = self.data
        if data is None:
            return super().cycle_frames()
        pdos = [*data.tpdos, *([data.rpdo] if data.rpdo is not None else [])]
        return [
            (
                f"{p.name} 0x{p.cob_id:03X} "
                f"({' '.join(_object(e.wire(self.axis_number), e.subindex) for e in p.entries)})",
                (p.bits + 7) // 8,
            )
            for p in pdos
        ]

    def _dq_feedback(self, data: ProcessData) -> Feedback:
        i_dq = complex(data.value((cia.DQ_CURRENT, 1)), data.value((cia.DQ_CURRENT, 2))) / 1000.0
        angle = data.value((cia.FRAME_ANGLE, 0)) * 1e-6
        if self._angle is not None:  # unwrap: a position like any other
            self._turns += round((self._angle - angle) / (2.0 * math.pi))
        self._angle = angle
        slot = data.slot_of((cia.DQ_CURRENT, 1))
        stamp = slot.timestamp if slot else None
        speed = data.value((cia.FRAME_SPEED, 0)) * 1e-3
        return Feedback(angle + 2.0 * math.pi * self._turns, speed, math.nan, abs(i_dq), stamp, i_dq)

    def supervise(self, now: float) -> None:
        """The node's watch (``drivers.node_watch.NodeWatch.check``: EMCY, NMT, heartbeat, other
        masters and producers), the statusword and, where mapped, 0x6061.

        Parameters
        ----------
        now : float
            [s] the time of the cycle (the heartbeat's age is measured to it).

        Raises
        ------
        SafetyStop
            The drive left OPERATION ENABLED or changed its mode (and ``NodeWatch.check``'s).
        """
        self.watch.check(now)  # CanopenAxis.supervise's, one call less each cycle
        assert self.data is not None
        plan = self._plan
        if plan.status is None:
            return
        slot, place = plan.status
        if slot.timestamp is None or slot.timestamp == self.states.enabled_stamp:
            return
        word = slot.values()[place]
        if word & _ENABLED_MASK != _ENABLED_BITS:
            raise SafetyStop(
                f"node {self.node_id}: the drive left OPERATION ENABLED: {power_state(word).value}"
            )
        if plan.mode is not None and plan.mode[0].timestamp is not None:  # not zeros before its first TPDO
            shown = plan.mode[0].values()[plan.mode[1]]
            if shown != self.op_mode:
                raise SafetyStop(f"node {self.node_id}: the drive changed its mode to {shown} (0x6061)")

    def command(self, value: float | complex) -> None:
        """Send the SI command of the mode in the RPDO (applied per its transmission type), with the
        controlword of the moment (enable operation; from a stop on, its command).

        Parameters
        ----------
        value : float or complex
            The mode's command in SI (complex: the dq voltage [V] in mode -2).
        """
        data = self.data
        assert data is not None and data.rpdo is not None
        if self.op_mode == Mode.DQ_VOLTAGE:
            u = complex(value)
            frame = data.frame({DQ_RX[0]: round(u.real * 1000.0), DQ_RX[1]: round(u.imag * 1000.0)})
        else:
            raw = self.units.command_raw(self.op_mode, float(value))  # type: ignore[arg-type]
            self._target_raw = raw
            frame = self._pack(data, raw)
        self._send_rpdo(data, frame)

    def keep_stopping(self) -> None:
        """Once a cycle of a stop (``rig.host.stopping``), before its SYNC: the command RPDO again,
        with the stop's controlword (quick stop, then disable voltage: never enable operation,
        which would take a drive whose 0x605A holds it in QUICK STOP ACTIVE back to OPERATION
        ENABLED, transition 16) and the neutral target (CSP: the last target; none sent, nothing),
        for as long as the drive may watch it: its disable not yet confirmed, or its deadline on
        the commands (0x1400+n sub 5) not yet lifted. So the deadline a drive holds, or its own
        watch of the cycle (0x60C2), sees the host alive through the ramp; a host that dies
        meanwhile still has the drive stop itself; and a quick stop whose SDO was lost still
        reaches the drive, in the RPDO's controlword."""
        data = self.data
        if self.states.stop_word is None or data is None or data.rpdo is None or not self._watched():
            return
        if self.op_mode == Mode.DQ_VOLTAGE:
            frame = data.frame({DQ_RX[0]: 0, DQ_RX[1]: 0})
        elif self.op_mode in (Mode.CSP, Mode.INTERPOLATED_POSITION):  # a place: the last target stands
            if self._target_raw is None:
                return
            frame = self._pack(data, self._target_raw)
        elif self.op_mode in cia.TARGET_OF_MODE:
            frame = self._pack(data, self.units.command_raw(self.op_mode, 0.0))
        else:
            return
        self._send_rpdo(data, frame)

    def _watched(self) -> bool:
        """The drive may still watch the host's commands (see ``keep_stopping``)."""
        return True

    def _pack(self, data: ProcessData, raw: int) -> bytes:
        """The RPDO's data: the controlword of the moment and the mode's target ``raw``."""
        plan = self._plan
        word = self.states.stop_word
        if word is None:
            word = plan.run_word
        if plan.rpdo is not None:
            return plan.rpdo(word, raw)
        return data.frame({CW: word, cia.TARGET_OF_MODE[self.op_mode]: raw})

    def _send_rpdo(self, data: ProcessData, frame: bytes) -> None:
        assert data.rpdo is not None
        try:
            self.network.send_message(data.rpdo.cob_id, frame)
        except RigError:
            raise
        except Exception as exc:  # python-can errors, a closed socket
            raise CommunicationError(f"node {self.node_id}: {data.rpdo.name} not sent: {brief(exc)}") from exc
