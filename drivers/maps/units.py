"""CiA 402 unit objects: the SI unit codes of 0x60A8/0x60A9 and the factor group, as numbers.

A CiA 402 drive states its position and velocity units in two ways:

- the factor group: position encoder resolution 0x608F (increments per motor
  revolution, sub 1 / sub 2), gear ratio 0x6091 (motor revolutions per driving
  shaft revolution, sub 1 / sub 2) and feed constant 0x6092 (feed in position
  units per driving shaft revolution, sub 1 / sub 2); without a unit object one
  position unit is gear x resolution / feed increments: with no gear and a feed
  of 1/1, one increment;
- the SI unit objects (CiA 402-2 with the unit codes of CiA 303-2, now CiA 890):
  0x60A8 position and 0x60A9 velocity, UNSIGNED32, bits 24-31 the prefix (a
  signed power of ten), bits 16-23 the unit, bits 8-15 the time unit of the
  denominator. 0xFF410000 is a tenth of a degree; 0x00B44700 is revolutions per
  minute.

``SiUnit.decode(code)`` gives a code's parts, and ``per_revolution`` /
``per_revolution_per_second`` how many of it make one revolution or one
revolution per second of the driving shaft. ``position_per_revolution`` and
``velocity_per_revolution`` give a drive's units per revolution of its motor
from whichever of these objects it has. Acceleration is in velocity units
per second.

A drive of DSP 402 v2 may state them by the older notation and dimension indices instead:
0x6089/0x608A (position) and 0x608B/0x608C (velocity), a power of ten and a unit code each.
``dimension_unit`` turns such a pair into the equivalent 0x60A8/0x60A9 code: a position
dimension is a rotary unit code of CiA 303-2 as 0x60A8 carries (0: increments, as without it);
a velocity dimension is 0xA4, revolutions per minute (the one rotary speed the drives' manuals
give this code for: Kollmorgen S300/S700 list 0xA4 = turn/min, 0xA6 = m/s, 0xA7 = m/min),
a linear unit is refused by name.

Decision: CiA 402 scales positions by the factor group only where the drive
has a feed constant 0x6092; a drive without 0x6092 and without 0x60A8 counts
positions in increments (its 0x608F, if any, then only tells the encoder's
resolution), as most drives without a factor group do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "ROTARY_UNITS",
    "TIME_UNITS",
    "SiUnit",
    "dimension_unit",
    "position_per_revolution",
    "velocity_per_revolution",
]

#: rotary units of CiA 303-2 (code: how many make one revolution)
ROTARY_UNITS: dict[int, float] = {
    0x10: 2.0 * math.pi,  # radian
    0x40: 400.0,  # grade (gon)
    0x41: 360.0,  # degree
    0x42: 360.0 * 60.0,  # arcminute
    0x43: 360.0 * 3600.0,  # arcsecond
    0xB4: 1.0,  # revolution
}
#: the code for encoder increments (how many make a revolution: the encoder resolution)
INCREMENTS = 0xB5
#: time units (code: seconds)
TIME_UNITS: dict[int, float] = {0x03: 1.0, 0x47: 60.0, 0x48: 3600.0, 0x49: 86400.0}
_NAMES = {
    0x10: "rad",
    0x40: "gon",
    0x41: "deg",
    0x42: "arcmin",
    0x43: "arcsec",
    0xB4: "rev",
    INCREMENTS: "inc",
}
_TIME_NAMES = {0x03: "s", 0x47: "min", 0x48: "h", 0x49: "d"}


@dataclass(frozen=True)
class SiUnit:
    """One SI unit object value: ``prefix`` (power of ten), ``unit`` and ``per`` (time unit, 0: none)."""

    prefix: int  #: the power of ten
    unit: int  #: the SI unit's code (CiA 402, 0x60A8)
    per: int = 0  #: the time unit's code (0: none)

    @classmethod
    def decode(cls, code: int) -> SiUnit:
        """The parts of an 0x60A8/0x60A9 value; ValueError naming a unit this toolkit cannot convert.

        Parameters
        ----------
        code : int
            An 0x60A8/0x60A9 value.

        Returns
        -------
        SiUnit
            Its parts.

        Raises
        ------
        ValueError
            If this toolkit cannot convert the unit.
        """
        prefix = (code >> 24) & 0xFF
        if prefix >= 0x80:
            prefix -= 0x100
        unit = cls(prefix, (code >> 16) & 0xFF, (code >> 8) & 0xFF)
        if unit.unit not in ROTARY_UNITS and unit.unit != INCREMENTS:
            raise ValueError(f"unit code 0x{code:08X}: unit 0x{unit.unit:02X} is not a rotary unit")
        if unit.per and unit.per not in TIME_UNITS:
            raise ValueError(f"unit code 0x{code:08X}: time unit 0x{unit.per:02X} is not known")
        return unit

    def encode(self) -> int:
        """The UNSIGNED32 value of this unit.

        Returns
        -------
        int
            The UNSIGNED32 value.
        """
        return (self.prefix & 0xFF) << 24 | self.unit << 16 | self.per << 8

    def per_revolution(self, increments_per_rev: float) -> float:
        """How many of this (position) unit make one revolution.

        Parameters
        ----------
        increments_per_rev : float
            The encoder's increments per revolution (for an increment unit).

        Returns
        -------
        float
            Units per revolution.
        """
        base = increments_per_rev if self.unit == INCREMENTS else ROTARY_UNITS[self.unit]
        return base * 10.0 ** (-self.prefix)

    def per_revolution_per_second(self, increments_per_rev: float) -> float:
        """How many of this (velocity) unit make one revolution per second.

        Parameters
        ----------
        increments_per_rev : float
            The encoder's increments per revolution (for an increment unit).

        Returns
        -------
        float
            Units per revolution per second.
        """
        seconds = TIME_UNITS.get(self.per, 1.0)
        return self.per_revolution(increments_per_rev) * seconds

    def __str__(self) -> str:
        scale = f"1e{self.prefix} " if self.prefix else ""
        per = f"/{_TIME_NAMES[self.per]}" if self.per else ""
        return f"{scale}{_NAMES.get(self.unit, hex(self.unit))}{per}"


#: velocity dimension indices (0x608C) of rotary speeds: the unit and time unit they stand for
VELOCITY_DIMENSIONS: dict[int, tuple[int, int]] = {0xA4: (0xB4, 0x47)}  # revolutions per minute


def dimension_unit(notation: int | None, dimension: int | None, *, velocity: bool) -> int:
    """The 0x60A8/0x60A9 code equivalent to a notation index (a power of ten; None: 0) and a
    dimension index (0x608A/0x608C; None or 0: not given, 0 returned); ValueError naming a
    dimension this toolkit cannot convert (a linear unit, an unknown code).

    Parameters
    ----------
    notation : int | None
        The notation index, a power of ten (None: 0).
    dimension : int | None
        The dimension index, 0x608A/0x608C (None or 0: not given).
    velocity : bool
        A velocity (else a position).

    Returns
    -------
    int
        The 0x60A8/0x60A9 code; 0 where no dimension is given.

    Raises
    ------
    ValueError
        If this toolkit cannot convert the dimension.
    """
    if not dimension:
        return 0
    prefix = notation or 0
    obj = "0x608C" if velocity else "0x608A"
    if velocity:
        if dimension not in VELOCITY_DIMENSIONS:
            raise ValueError(
                f"{obj} = 0x{dimension:02X}: a velocity dimension index that is no rotary speed drive-rig "
                "knows (0xA4: revolutions per minute)"
            )
        unit, per = VELOCITY_DIMENSIONS[dimension]
        return SiUnit(prefix, unit, per).encode()
    if dimension not in ROTARY_UNITS and dimension != INCREMENTS:
        raise ValueError(f"{obj} = 0x{dimension:02X}: a position dimension index that is no rotary unit")
    return SiUnit(prefix, dimension).encode()


def position_per_revolution(
    increments: float, *, gear: float = 1.0, feed: float | None = None, unit: int = 0
) -> float:
    """Position units per motor revolution: from the SI unit code ``unit`` (0x60A8) if given, else
    from the feed constant ``feed`` (0x6092, units per driving shaft revolution) if the drive has
    one, else increments. ``increments``: per motor revolution (0x608F); ``gear``: motor
    revolutions per driving shaft revolution (0x6091).

    Parameters
    ----------
    increments : float
        Per motor revolution (0x608F).
    gear : float, optional
        Motor revolutions per driving-shaft revolution (0x6091).
    feed : float | None, optional
        Units per driving-shaft revolution (0x6092; None: none).
    unit : int, optional
        The SI unit code (0x60A8; 0: not given).

    Returns
    -------
    float
        Position units per motor revolution.
    """
    if unit:
        return SiUnit.decode(unit).per_revolution(increments) / gear
    if feed is not None:
        return feed / gear
    return increments


def velocity_per_revolution(
    increments: float, *, gear: float = 1.0, feed: float | None = None, unit: int = 0, position_unit: int = 0
) -> float:
    """Velocity units per motor revolution per second: from the SI unit code ``unit`` (0x60A9) if
    given, else position units (``position_unit``: 0x60A8, see ``position_per_revolution``) per
    second.

    Parameters
    ----------
    increments : float
        Per motor revolution (0x608F).
    gear : float, optional
        Motor revolutions per driving-shaft revolution (0x6091).
    feed : float | None, optional
        Units per driving-shaft revolution (0x6092; None: none).
    unit : int, optional
        The SI unit code (0x60A9; 0: not given).
    position_unit : int, optional
        0x60A8, where ``unit`` is not given.

    Returns
    -------
    float
        Velocity units per motor revolution per second.
    """
    if unit:
        return SiUnit.decode(unit).per_revolution_per_second(increments) / gear
    return position_per_revolution(increments, gear=gear, feed=feed, unit=position_unit)
