"""Before ``rig drive`` moves a drive in a profile mode, with nothing sent yet: the drive offers the
mode (0x6502), its dictionary has what the mode needs (``check_offered``) and the factors to SI it
needs are known (``check_profile``)."""

from __future__ import annotations

from drivers.cia402 import Cia402Axis
from drivers.cia402_units import require
from drivers.errors import ConfigError
from drivers.identity import STANDARD_WRITES
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.cia402_needs import needed
from drivers.maps.cia402_needs import require as require_objects
from drivers.maps.mode_names import mode_text
from rig.commission.status import UNITS_HINT

__all__ = ["check_offered", "check_profile"]


def check_offered(a: Cia402Axis, mode: Mode, verb: str) -> None:
    """ConfigError, before anything is sent, where the drive's 0x6502 does not list ``mode``, or
    its dictionary lacks what the mode needs (``drivers.maps.cia402_needs``; met without its
    EDS, an object of ``drivers.identity.STANDARD_WRITES`` is the device's to refuse).

    Parameters
    ----------
    a : Cia402Axis
        The drive, discovered.
    mode : Mode
        The mode.
    verb : str
        The command, named in the error.

    Raises
    ------
    ConfigError
        If the drive lacks the mode or what it needs.
    """
    found = a.discovery
    if found.supported_modes is not None and int(mode) not in found.supported_modes:
        raise ConfigError(
            f"{a.where}: rig drive {verb} runs the drive in {mode_text(int(mode))}, which it does not "
            f"offer ({found.offered(found.optional(cia.SUPPORTED_MODES))}); nothing was sent: use a mode it "
            "offers (rig run with mode = csp, csv or cst, where it lists them)"
        )
    needs = (*needed(mode), cia.VELOCITY_ACTUAL)  # the stop watches the speed to rest
    if not a.eds_given:  # met without its EDS: a standard object is written by its type
        needs = tuple(i for i in needs if (i, 0) not in STANDARD_WRITES)
    require_objects(a.node.object_dictionary, needs, source=a.eds, what=f"rig drive {verb}")


def check_profile(a: Cia402Axis, mode: Mode, verb: str) -> None:
    """Before a move in a profile mode (``DriveTool.run_profile``): the drive discovered, the mode
    offered (``check_offered``) and, for profile position and velocity, the factors it needs.

    Parameters
    ----------
    a : Cia402Axis
        The drive.
    mode : Mode
        The profile mode.
    verb : str
        The command, named in an error.
    """
    a.discover(check_mode=False)
    check_offered(a, mode, verb)
    if mode in (Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY):
        require(
            a.units,
            int(mode),
            where=f"{a.name!r} ({a.where})",
            hint=UNITS_HINT,
            has_position=a.discovery.has_position,
        )
