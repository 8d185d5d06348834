"""What the host may write to a CiA 402 drive, and how it writes a setting the drive may refuse.

The drive's own EDS says what each entry is (its access type: ro, wo, rw, const); the host
writes only entries declared writable and only what its task needs, reads the others and
takes their value as it is.

- ``Setting``: one write the set-up wants. ``apply`` reads an entry the EDS declares
  read-only or constant (never writes it) and says whether it already holds the value;
  writes a writable one; an abort is one warning for an optional setting, and, for a required
  one, a ``ConfigError`` naming the object, the abort code in words and the access type the
  EDS declares.
- ``interpolation_period``: 0x60C2 in the drive's own exponent where it can be, with the
  period actually in force where it cannot.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from drivers.cia402_pdo import variable
from drivers.errors import ConfigError, NotInDictionary, SdoAbort
from drivers.maps.sdo_aborts import abort_text

__all__ = ["Setting", "interpolation_period", "period_text"]

log = logging.getLogger(__name__)


def _name(od: Any, index: int, subindex: int) -> str:
    var = variable(od, (index, subindex))
    name = str(var.name) if var is not None else ""
    return f" ({name})" if name else ""


@dataclass
class Setting:
    """A write the set-up wants: ``value`` into (``index``, ``subindex``) for ``why``."""

    index: int  #: the entry's index
    subindex: int  #: its sub-index
    value: Any  #: what it should hold
    why: str  #: what it is for, for messages
    required: bool = False  #: a refusal is a ConfigError (else one warning)
    then: str = ""  #: what to do where a required one is refused

    def apply(
        self, od: Any, read: Callable[[int, int], Any], write: Callable[[int, int, Any], None], where: str
    ) -> bool:
        """Write the setting where the EDS declares it writable, else read it (module docstring).

        Parameters
        ----------
        od : canopen.ObjectDictionary
            The dictionary in use.
        read : callable
            ``read(index, subindex)``: an SDO upload.
        write : callable
            ``write(index, subindex, value)``: an SDO download.
        where : str
            The drive, for messages.

        Returns
        -------
        bool
            The drive holds ``value`` afterwards.

        Raises
        ------
        ConfigError
            A required setting the drive cannot hold or refused.
        """
        var = variable(od, (self.index, self.subindex))
        obj = f"0x{self.index:04X}:{self.subindex:02X}{_name(od, self.index, self.subindex)}"
        access = getattr(var, "access_type", "?") if var is not None else "absent"
        if var is not None and not var.writable:
            held = read(self.index, self.subindex) if var.readable else None
            if held == self.value:
                return True
            said = (
                f"{where}: {obj} is {access} in the EDS and holds {held!r}; {self.why} wanted {self.value!r}"
            )
            if self.required:
                raise ConfigError(f"{said}: the drive cannot do what is asked{self._then}")
            log.warning("%s; not written", said)
            return False
        try:
            write(self.index, self.subindex, self.value)
        except SdoAbort as exc:
            declared = f"the EDS declares it {access}" if var is not None else "the EDS in use lacks it"
            said = (
                f"{exc} ({self.why})"
                if isinstance(exc, NotInDictionary)  # nothing was sent
                else f"{where}: {obj} refused {self.value!r} ({self.why}): abort 0x{exc.code:08X}, "
                f"{abort_text(exc.code)}; {declared}"
            )
            if self.required:
                raise ConfigError(said + self._then) from exc
            log.warning("%s; going on without it", said)
            return False
        return True

    @property
    def _then(self) -> str:
        return f"; {self.then}" if self.then else ""


def interpolation_period(
    period: float, exponent: int | None, writable: bool
) -> tuple[int, int | None, float]:
    """0x60C2 for a SYNC period of ``period`` [s]: (value, exponent to write or None, period in
    force [s]). The drive's own ``exponent`` (sub 2 as read; None: not readable) is kept where
    the period is a whole number 1-255 of it; else, where sub 2 is ``writable``, the first
    exponent -6..2 that gives one; else the nearest value in the drive's exponent.

    Parameters
    ----------
    period : float
        [s] the SYNC period.
    exponent : int or None
        0x60C2:02 as read (None: not readable).
    writable : bool
        0x60C2:02 may be written.

    Returns
    -------
    tuple of (int, int or None, float)
        The value, the exponent to write (None: keep the drive's) and the period in force [s].

    Raises
    ------
    ConfigError
        No exponent is known and none gives the period.
    """
    candidates = ([exponent] if exponent is not None else []) + (list(range(-6, 3)) if writable else [])
    for e in candidates:
        value = period / 10.0**e
        if 1 <= round(value) <= 255 and abs(value - round(value)) < 1e-6 * max(1.0, value):
            return round(value), (None if e == exponent else e), round(value) * 10.0**e
    if exponent is None:
        raise ConfigError(
            f"SYNC period {period!r} s cannot be written to 0x60C2 (value x 10^n, value <= 255)"
        )
    value = min(255, max(1, round(period / 10.0**exponent)))
    return value, None, value * 10.0**exponent


def period_text(seconds: float) -> str:
    """A period for a person: ``1 ms``, ``400 us``, ``0.01 s``.

    Parameters
    ----------
    seconds : float
        [s] the period.

    Returns
    -------
    str
        It, in s, ms or us.
    """
    if seconds >= 1.0 or not math.isfinite(seconds):
        return f"{seconds:g} s"
    if seconds >= 1e-3:
        return f"{seconds * 1e3:g} ms"
    return f"{seconds * 1e6:g} us"
