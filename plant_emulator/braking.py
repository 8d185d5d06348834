"""How an emulated CiA 402 drive stops on its own: the ramps of quick stop, fault reaction and halt.

A real drive does not cut the power when it is told to stop: it brakes its
motor with its speed loop along a ramp that an option code selects (CiA 402-2,
0x605A quick stop, 0x605E fault reaction, 0x605D halt):

- 0: disable drive function: the power stage is switched off, the motor coasts
  (0x605A/0x605E only);
- 1 (and 5): slow down ramp, the profile deceleration 0x6084;
- 2 (and 6): quick stop ramp, the quick stop deceleration 0x6085;
- 3, 4 (and 7, 8): brake at the current (or voltage) limit: the speed set-point
  goes to zero at once and the speed loop brakes with the torque it has.

Options 5-8 of 0x605A brake the same way and then hold the motor at rest in
QUICK STOP ACTIVE (the state machine's part). ``Braking`` is the speed
set-point of one stop: ``start`` with the speed at the stop, then ``step``
once per control period.
"""

from __future__ import annotations

import math

__all__ = ["STOPPED_SPEED", "Braking", "deceleration"]

#: below this speed [rad/s] a braking drive counts the motor as stopped
STOPPED_SPEED = 1e-2


def deceleration(option: int, *, profile: float, quick_stop: float) -> float | None:
    """The deceleration [rad/s^2] of stop option ``option`` (see the module docstring): None to
    coast, ``math.inf`` to brake at the limit; ``profile`` and ``quick_stop`` [rad/s^2] are the
    drive's 0x6084 and 0x6085 in SI.

    Parameters
    ----------
    option : int
        A quick-stop or fault-reaction option code (0x605A/0x605E).
    profile : float
        [rad/s^2] the drive's 0x6084.
    quick_stop : float
        [rad/s^2] its 0x6085.

    Returns
    -------
    float | None
        [rad/s^2]; None: coast; ``math.inf``: brake at the limit.
    """
    if option <= 0:
        return None
    if option in (1, 5):
        return profile
    if option in (2, 6):
        return quick_stop
    return math.inf


class Braking:
    """The speed set-point [rad/s] of a drive's own stop (see the module docstring)."""

    __slots__ = ("cause", "rate", "reference")

    def __init__(self) -> None:
        self.reference: float | None = None  #: None: not braking
        self.rate = math.inf  #: [rad/s^2]
        self.cause: object = None  #: what the stop is for (the drive's state when it started)

    @property
    def active(self) -> bool:
        return self.reference is not None

    def start(self, velocity: float, rate: float, *, cause: object = None) -> None:
        """Brake from ``velocity`` [rad/s] at ``rate`` [rad/s^2] (> 0; inf: at the limit), for ``cause``.

        Parameters
        ----------
        velocity : float
            [rad/s] the set-point braking starts from.
        rate : float
            [rad/s^2] > 0 (inf: at the limit).
        cause : object, optional
            What stops the drive (kept for the caller).

        Raises
        ------
        ValueError
            If ``rate`` <= 0.
        """
        if not rate > 0.0:
            raise ValueError(f"a braking deceleration must be > 0 rad/s^2, got {rate!r}")
        self.reference, self.rate, self.cause = velocity, rate, cause

    def step(self, h: float) -> float:
        """The set-point after ``h`` [s] more of braking.

        Parameters
        ----------
        h : float
            [s] of braking.

        Returns
        -------
        float
            [rad/s] the set-point.

        Raises
        ------
        RuntimeError
            If called before ``start``.
        """
        ref = self.reference
        if ref is None:
            raise RuntimeError("Braking.step() before start()")
        dv = self.rate * h
        ref = 0.0 if abs(ref) <= dv else ref - math.copysign(dv, ref)
        self.reference = ref
        return ref

    def release(self) -> None:
        """Braking over: no set-point, no cause."""
        self.reference = self.cause = None
