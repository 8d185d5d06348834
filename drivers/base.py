"""The one contract every axis driver keeps, in the manner of python-can's ``BusABC``.

An axis is one device of a rig seen from the host: a CiA 402 drive, a Modbus
inverter, a CiA 406 encoder. The host loop knows axes through this contract
only, never their protocol::

    axis.idle = f                 # what waiting for the device calls (a SYNC in lock-step)
    axis.setup()                  # identity, units, mode, process data; nothing moves
    axis.enable(timeout=1.0)      # the device follows commands from now on
    fb = axis.feedback()          # SI: rad, rad/s, N m, A
    axis.supervise(now)           # raises when the device reports trouble
    axis.command(u)               # SI, in the unit of the axis's mode
    axis.quick_stop()             # the device's own ramp; each cycle of it
    axis.keep_stopping()          # keeps the device's watch of the host fed; once
    axis.at_rest(fb)              # says its stop ended,
    axis.disable()                # confirmed, and only then its watch lifted
    axis.close()                  # idempotent; leaves the device disabled
    axis.abandon()                # or: leaves the device as it is, no I/O (another master's)

Every library exception (canopen, pymodbus, python-can, OS) is translated into
the toolkit's tree (``drivers.errors``) inside the driver, once, with
``raise ... from``: callers of an axis catch ``RigError`` only.
"""

from __future__ import annotations

import abc
import enum
import logging
import math
import operator
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

__all__ = ["AXIS_MODES", "POSITION_COMMANDS", "AxisDriver", "AxisState", "Feedback", "feedback_fields"]

log = logging.getLogger(__name__)

#: the command each mode takes, in SI
AXIS_MODES = {
    "voltage": "armature voltage [V]",
    "cst": "torque [N m]",
    "csv": "speed [rad/s]",
    "pv": "speed [rad/s]",
    "csp": "position [rad]",
    "ip": "position [rad], one set-point a SYNC, interpolated by the drive",
    "dq-voltage": "dq voltage u_d + j u_q [V] (complex)",
    "speed": "speed reference [rad/s]",
}
POSITION_COMMANDS = frozenset({"csp", "ip"})  #: the modes whose command is a position [rad]


class AxisState(enum.Enum):
    """What an axis does, whatever its protocol."""

    DISABLED = "disabled"  #: no torque; may be enabled
    ENABLED = "enabled"  #: follows the commands
    STOPPING = "stopping"  #: a quick-stop ramp or fault reaction runs
    FAULT = "fault"  #: stopped by a fault; needs a reset
    UNKNOWN = "unknown"  #: the device did not say


@dataclass(slots=True)
class Feedback:
    """One sample of an axis in SI; NaN where the axis does not measure the quantity."""

    position: float = math.nan  #: [rad]
    velocity: float = math.nan  #: [rad/s]
    torque: float = math.nan  #: [N m]
    current: float = math.nan  #: [A] (|i| for a dq axis)
    stamp: float | None = None  #: changes with every new sample (receive time [s] or a count)
    i_dq: complex | None = None  #: dq current [A], dq axes only


def _pause() -> None:
    """The default ``AxisDriver.idle``: 1 ms of the wall clock."""
    time.sleep(0.001)


def feedback_fields(names: Iterable[str]) -> Callable[[Feedback], tuple[Any, ...]]:
    """A function giving a sample's fields ``names`` (in that order) as a tuple, in one call.

    Parameters
    ----------
    names : Iterable[str]
        ``Feedback`` field names.

    Returns
    -------
    Callable[[Feedback], tuple[Any, ...]]
        A sample -> those fields, as a tuple.
    """
    names = tuple(names)
    if len(names) > 1:
        return operator.attrgetter(*names)
    if names:
        name = names[0]
        return lambda fb: (getattr(fb, name),)
    return lambda fb: ()


class AxisDriver(abc.ABC):
    """Base of every axis driver; see the module docstring.

    Subclasses set ``measures`` (the Feedback fields they fill) and implement the
    abstract hooks. ``close`` calls ``disable`` once, logs (never raises) a
    failure, and then ``_release``; it is safe to call twice. An axis that is
    never closed warns (ResourceWarning) when collected.

    Parameters
    ----------
    name : str
        The axis's name, in messages.
    mode : str | None
        One of ``AXIS_MODES`` (None: an axis that takes no commands).

    Raises
    ------
    ValueError
        If ``mode`` is not one of ``AXIS_MODES``.
    """

    #: Feedback fields this kind of axis fills
    measures: frozenset[str] = frozenset()
    #: what a sample is called in messages ("no TPDO for 3 periods")
    sample_name: ClassVar[str] = "sample"
    #: in real time, a sample's ``stamp`` is its receive time on the wall clock (``time.time()`` [s])
    wall_stamps: ClassVar[bool] = False

    def __init__(self, name: str, mode: str | None) -> None:
        if mode is not None and mode not in AXIS_MODES:
            raise ValueError(f"axis {name!r}: unknown mode {mode!r}; known: {', '.join(AXIS_MODES)}")
        self.name = name  #: the configuration's axis name
        self.mode = mode  #: what ``command`` takes; None for a feedback-only axis
        self._closed = False
        #: what the driver calls while it waits for the device (set-up, a disable's confirmation):
        #: lets time pass; the host sets it where time is its SYNCs' (lock-step), else a short sleep
        self.idle: Callable[[], None] = _pause

    @property
    def commandable(self) -> bool:
        """True if ``command`` may be called (the axis has a mode)."""
        return self.mode is not None

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} {self.where}>"

    @property
    @abc.abstractmethod
    def where(self) -> str:
        """Where the device is, for messages (``node 1``, ``unit 1 at 127.0.0.1:502``)."""

    @abc.abstractmethod
    def setup(self) -> None:
        """Check the device's identity, read its units, select the mode, set up process data.

        Leaves the device disabled. Raises ConfigError when the device cannot do
        what the configuration asks, naming the object or register.
        """

    @abc.abstractmethod
    def enable(self, *, timeout: float = 1.0) -> None:
        """Bring the device to follow commands within ``timeout`` [s]; a zero command is held.

        Parameters
        ----------
        timeout : float, optional
            [s] for the device to follow commands.
        """

    @abc.abstractmethod
    def disable(self) -> None:
        """Remove torque (voltage off); the device stays configured."""

    @abc.abstractmethod
    def quick_stop(self) -> None:
        """Stop with the device's own quick-stop ramp."""

    def keep_stopping(self) -> None:  # noqa: B027 - a hook with a default
        """Once a cycle of a stop, before its SYNC: what the device needs from the host meanwhile
        so that its own watch of the host (a deadline on the commands) sees it alive until the
        disable is confirmed. The default sends nothing."""

    @abc.abstractmethod
    def feedback(self) -> Feedback:
        """The latest sample in SI (from the last process data, or read now).

        Returns
        -------
        Feedback
            The latest sample, SI units.
        """

    def neutral_command(self) -> float | complex | None:
        """The command that asks for no effort, sent before the quick stop: 0 (V, N m, rad/s),
        0j in dq; None for a position (CSP): 0 rad is a place, not a stop; the last target
        stands and the drive's quick-stop ramp starts from it.

        Returns
        -------
        float | complex | None
            0 (V, N m, rad/s) or 0j (dq); None in a position mode.
        """
        if self.mode in POSITION_COMMANDS:
            return None
        return 0j if self.mode == "dq-voltage" else 0.0

    def quanta(self) -> tuple[float, float]:
        """The resolution of the measurement: (one position count [rad], one speed unit [rad/s]);
        0 where the axis does not say or does not measure (after ``setup``).

        Returns
        -------
        tuple[float, float]
            (one position count [rad], one speed unit [rad/s]); 0 where unknown.
        """
        return (0.0, 0.0)

    def foreign_sample(self, before: Feedback, after: Feedback) -> str | None:
        """Where the sample ``after``, taken one SYNC after ``before``, cannot be the device's
        (its position contradicts its own measured speed: another producer's frame), in words
        naming the COB-ID or register and the device; None where it can (the default: no check).

        Parameters
        ----------
        before : Feedback
            A sample.
        after : Feedback
            The sample one SYNC later.

        Returns
        -------
        str | None
            Why ``after`` cannot be the device's, naming the COB-ID or register; None where it can.
        """
        return None

    def has_sample(self) -> bool:
        """Every value ``feedback`` gives has come from the device at least once (not the
        placeholder zeros of a TPDO still to arrive). The default: feedback reads the device.

        Returns
        -------
        bool
            Every value of ``feedback`` has come from the device at least once.
        """
        return True

    def command(self, value: float | complex) -> None:
        """Send ``value`` in the SI unit of the mode (``AXIS_MODES``).

        Parameters
        ----------
        value : float | complex
            In the mode's SI unit (``AXIS_MODES``).

        Raises
        ------
        NotImplementedError
            If the axis takes no commands (the default).
        """
        raise NotImplementedError(f"{self!r} takes no commands")

    def supervise(self, now: float) -> None:  # noqa: B027 - a hook with a default
        """Raise SafetyStop, DeviceFault or CommunicationError if the device reports trouble.

        Called once per cycle after ``feedback``; ``now`` is the bus clock [s]
        (the clock of the frames' timestamps). The default checks nothing.

        Parameters
        ----------
        now : float
            [s] the bus clock.
        """

    #: below this speed [rad/s] a stopping axis counts as at rest (``rest_speed``'s default)
    REST_SPEED: ClassVar[float] = 0.05
    #: the at-rest window [rad/s] and the time [s] the speed must stay in it after ``disable``
    #: for the host to confirm the stop (``rig.host.stopping``; [axis.limits] rest_speed,
    #: rest_time, as CiA 402's velocity threshold 0x606F and its time 0x6070 say "speed = 0")
    rest_speed: float = REST_SPEED
    rest_time: float = 0.1
    _speed_stamp: object = None  #: the stamp of the sample ``shaft_speed`` last gave

    def at_rest(self, fb: Feedback) -> bool:
        """After ``quick_stop``: True once the device's own stop has ended (``fb``: its latest
        sample). The default: the speed it measures is below ``rest_speed`` (or it measures none).

        Parameters
        ----------
        fb : Feedback
            The latest sample.

        Returns
        -------
        bool
            The device's own stop has ended.
        """
        return "velocity" not in self.measures or abs(fb.velocity) < self.rest_speed

    @property
    def has_shaft(self) -> bool:
        """The axis measures a shaft's speed, whose rest confirms its stop (a dq axis's speed is
        its frame's, not a shaft's)."""
        return "velocity" in self.measures and self.mode != "dq-voltage"

    def shaft_speed(self) -> float | None:
        """The shaft's speed [rad/s] in a sample newer than the last call's; None: none new yet.
        The default: ``feedback``'s, new when its stamp changed (or it has none).

        Returns
        -------
        float | None
            [rad/s] a speed newer than the last call's; None: none new yet.
        """
        fb = self.feedback()
        if fb.stamp is not None and fb.stamp == self._speed_stamp:
            return None
        self._speed_stamp = fb.stamp
        return fb.velocity

    @abc.abstractmethod
    def read_state(self) -> AxisState:
        """Ask the device for its state (I/O).

        Returns
        -------
        AxisState
            The device's state.
        """

    @property
    def fault(self) -> Exception | None:
        """The last fault the device reported (DeviceFault), or None."""
        return None

    def _release(self) -> None:  # noqa: B027 - a hook with a default
        """Release connections and subscriptions (after the device is disabled)."""

    def close(self) -> None:
        """Disable the device (once; a failure is logged) and release it; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        try:
            self.disable()
        except Exception as exc:  # the device may be gone: closing must not raise
            log.warning("%s: disabling on close failed: %s", self.where, exc)
        self._release()

    def abandon(self) -> None:
        """Leave the device as it is, with no I/O (no disable: another master's drive, or a tool
        that leaves it as its command left it), and release connections; then as closed."""
        if not self._closed:
            self._closed = True
            self._release()

    def __enter__(self) -> AxisDriver:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        if not getattr(self, "_closed", True):
            warnings.warn(f"{self!r} was never closed", ResourceWarning, stacklevel=2)

    def _forget(self) -> None:
        """Mark closed without I/O (for an axis whose setup failed before it touched the device)."""
        self._closed = True
