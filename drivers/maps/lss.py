"""Layer setting services (LSS, CiA 305) on the wire: COB-IDs, command specifiers, the bit timing
table and the answers' error codes, in words. One definition for the emulated LSS slave
(``plant_emulator.lss_slave``) and the host's LSS commands (``rig.commission.lss``, through
canopen's ``LssMaster``).

Every LSS frame is 8 bytes: the command specifier, then its data (little-endian), zeros after.
"""

from __future__ import annotations

import enum

__all__ = [
    "BIT_TIMINGS",
    "COB_MASTER",
    "COB_SLAVE",
    "FASTSCAN_CONFIRM",
    "UNCONFIGURED",
    "Cs",
    "LssState",
    "error_text",
]

COB_MASTER, COB_SLAVE = 0x7E5, 0x7E4  #: master -> slaves, slave -> master
UNCONFIGURED = 0xFF  #: the node-ID of a device that has none (answers LSS only)
FASTSCAN_CONFIRM = 0x80  #: fastscan's bit checked that starts a scan (every unconfigured slave answers)

#: CiA 305's bit timing table (table selector 0): index -> bit rate [bit/s]; 5 is reserved, 9 is
#: automatic bit rate detection (a master sets no such rate)
BIT_TIMINGS = {0: 1_000_000, 1: 800_000, 2: 500_000, 3: 250_000, 4: 125_000, 6: 50_000, 7: 20_000, 8: 10_000}


class LssState(enum.IntEnum):
    """The LSS slave's states (switch state global's mode byte)."""

    WAITING = 0
    CONFIGURATION = 1


class Cs(enum.IntEnum):
    """Command specifiers (byte 0 of an LSS frame)."""

    SWITCH_GLOBAL = 0x04
    CONFIGURE_NODE_ID = 0x11
    CONFIGURE_BIT_TIMING = 0x13
    ACTIVATE_BIT_TIMING = 0x15
    STORE_CONFIGURATION = 0x17
    SELECT_VENDOR = 0x40  #: switch state selective: vendor-ID, product code, revision, serial (0x43)
    SELECT_SERIAL = 0x43
    SELECTED = 0x44  #: the slave's answer to a selective switch that named it
    IDENTIFY_VENDOR = 0x46  #: identify remote slave: vendor, product, revision low/high, serial low/high
    IDENTIFY_SERIAL_HIGH = 0x4B
    IDENTIFY_NON_CONFIGURED = 0x4C
    IDENTIFY_SLAVE = 0x4F  #: a slave's answer to identify remote slave and to fastscan
    NON_CONFIGURED_SLAVE = 0x50  #: an unconfigured slave's answer to 0x4C
    FASTSCAN = 0x51
    INQUIRE_VENDOR = 0x5A  #: inquire identity: vendor, product, revision, serial (0x5D)
    INQUIRE_SERIAL = 0x5D
    INQUIRE_NODE_ID = 0x5E


#: the answers' error codes (byte 1) in words, per service; 255 is manufacturer-specific (byte 2)
_ERRORS: dict[int, dict[int, str]] = {
    Cs.CONFIGURE_NODE_ID: {1: "node-ID out of range (1..127, or 255: none)"},
    Cs.CONFIGURE_BIT_TIMING: {1: "bit rate not supported"},
    Cs.STORE_CONFIGURATION: {
        1: "storing the configuration is not supported",
        2: "storage media access error",
    },
}


def error_text(cs: int, code: int, specific: int = 0) -> str:
    """An LSS answer's error code ``code`` to service ``cs`` in words.

    Parameters
    ----------
    cs : int
        The LSS service's command specifier.
    code : int
        The error code answered.
    specific : int, optional
        The manufacturer's code (``code`` 255).

    Returns
    -------
    str
        The error in words.
    """
    if code == 255:
        return f"manufacturer-specific error {specific} (its manual says what it means)"
    return _ERRORS.get(cs, {}).get(code, f"error {code}, which CiA 305 does not list")
