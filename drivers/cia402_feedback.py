"""What a CiA 402 drive's TPDOs may carry, by name (an axis's ``feedback``), and its check.

The names are those of ``drivers.cia402_mapping.FEEDBACK`` (the objects they map); this module
imports nothing heavy, so a configuration is checked at load without python-can or canopen.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["FEEDBACK_NAMES", "feedback_problem"]

#: statusword 0x6041 always; position 0x6064 (always), velocity 0x606C, mode 0x6061 (the mode
#: shown), torque 0x6077, current 0x6078
FEEDBACK_NAMES = ("position", "velocity", "mode", "torque", "current")


def feedback_problem(names: Iterable[str]) -> str:
    """Check what an axis's TPDOs are to carry (its ``feedback``, at load and in the driver).

    Parameters
    ----------
    names : iterable of str
        The feedback names, of ``FEEDBACK_NAMES``.

    Returns
    -------
    str
        What is wrong with them, or "".
    """
    names = list(names)
    if "position" in names and all(n in FEEDBACK_NAMES for n in names):
        return ""
    return f"feedback = {names}: position and any of {', '.join(FEEDBACK_NAMES[1:])}"
