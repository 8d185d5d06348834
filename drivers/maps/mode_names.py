"""The configuration's names of the CiA 402 modes of operation (``mode = "csv"`` in an
``[[axis]]`` table), and the mode a name or number stands for. The modes themselves, with their
numbers on the wire, are ``drivers.maps.cia.Mode``."""

from __future__ import annotations

from drivers.maps.cia import Mode

__all__ = ["MODE_NAMES", "mode_code"]

MODE_NAMES = {
    "pp": Mode.PROFILE_POSITION,
    "pv": Mode.PROFILE_VELOCITY,
    "tq": Mode.PROFILE_TORQUE,
    "csp": Mode.CSP,
    "csv": Mode.CSV,
    "cst": Mode.CST,
    "voltage": Mode.VOLTAGE,
    "dq-voltage": Mode.DQ_VOLTAGE,
}


def mode_code(mode: str | int) -> Mode:
    """A mode by its configuration name or number; ValueError naming the known ones."""
    if isinstance(mode, str):
        if mode in MODE_NAMES:
            return MODE_NAMES[mode]
    else:
        try:
            return Mode(mode)
        except ValueError:
            pass
    raise ValueError(f"unknown CiA 402 mode {mode!r}; known: {', '.join(MODE_NAMES)}")
