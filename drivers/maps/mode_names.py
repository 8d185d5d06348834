"""The configuration's names of the CiA 402 modes of operation (``mode = "csv"`` in an
``[[axis]]`` table), and the mode a name or number stands for. The modes themselves, with their
numbers on the wire, are ``drivers.maps.cia.Mode``."""

from __future__ import annotations

from drivers.maps.cia import Mode

__all__ = ["MODE_NAMES", "mode_code", "mode_text"]

MODE_NAMES = {
    "pp": Mode.PROFILE_POSITION,
    "pv": Mode.PROFILE_VELOCITY,
    "tq": Mode.PROFILE_TORQUE,
    "csp": Mode.CSP,
    "ip": Mode.INTERPOLATED_POSITION,
    "csv": Mode.CSV,
    "cst": Mode.CST,
    "voltage": Mode.VOLTAGE,
    "dq-voltage": Mode.DQ_VOLTAGE,
}


def mode_code(mode: str | int) -> Mode:
    """A mode by its configuration name or number.

    Parameters
    ----------
    mode : str or int
        A name of ``MODE_NAMES`` or a mode number (0x6060).

    Returns
    -------
    Mode
        The mode's number.

    Raises
    ------
    ValueError
        Naming the known modes when ``mode`` is none of them.
    """
    if isinstance(mode, str):
        if mode in MODE_NAMES:
            return MODE_NAMES[mode]
    else:
        try:
            return Mode(mode)
        except ValueError:
            pass
    raise ValueError(f"unknown CiA 402 mode {mode!r}; known: {', '.join(MODE_NAMES)}")


#: CiA 402's words for each mode number it defines (0x6060/0x6061; CiA 402-2, 6.5)
_CIA_WORDS = {
    0: "no mode",
    1: "profile position",
    2: "velocity (vl)",
    3: "profile velocity",
    4: "profile torque",
    6: "homing",
    7: "interpolated position",
    8: "cyclic synchronous position",
    9: "cyclic synchronous velocity",
    10: "cyclic synchronous torque",
    11: "cyclic synchronous torque with commutation angle (cstca)",
}
_SHORT = {int(code): name for name, code in MODE_NAMES.items()}


def mode_text(code: int, *, toolkit: bool = True) -> str:
    """A mode number in words (``cyclic synchronous position (csp)``).

    Parameters
    ----------
    code : int
        The mode number (0x6060, 0x6061).
    toolkit : bool
        The device is the toolkit's own drive: its manufacturer modes (negative) are named.

    Returns
    -------
    str
        The mode in words.
    """
    code = int(code)
    if code in _CIA_WORDS:
        short = _SHORT.get(code)
        return _CIA_WORDS[code] + (f" ({short})" if short else "")
    if code < 0 and toolkit and code in _SHORT:
        return f"{_SHORT[code]} (drive-rig's manufacturer mode {code})"
    if code < 0:
        return f"manufacturer mode {code} (the vendor's own)"
    return f"mode {code} (reserved)"
