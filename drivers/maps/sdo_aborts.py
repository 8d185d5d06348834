"""SDO abort codes in words, as CiA 301 lists them (7.2.4.3.17, "Protocol SDO abort transfer":
the table of abort codes, the block-transfer ones included). The codes the toolkit's own devices
answer with are ``SdoAbortCode``; ``abort_text`` is what the host says of any code a
drive sends."""

from __future__ import annotations

import enum

__all__ = ["ABORT_TEXTS", "SdoAbortCode", "abort_text"]


class SdoAbortCode(enum.IntEnum):
    """SDO abort codes (CiA 301, 7.2.4.3.17) that the devices answer with."""

    COMMAND_SPECIFIER = 0x05040001  #: client/server command specifier not valid or unknown
    WRITE_ONLY = 0x06010001
    READ_ONLY = 0x06010002
    NO_OBJECT = 0x06020000
    NOT_MAPPABLE = 0x06040041  #: object cannot be mapped to the PDO
    PDO_LENGTH_EXCEEDED = 0x06040042  #: number and length of mapped objects exceed the PDO
    LENGTH_MISMATCH = 0x06070010
    NO_SUBINDEX = 0x06090011
    VALUE_RANGE_EXCEEDED = 0x06090030  #: value range of parameter exceeded (write access)
    VALUE_TOO_HIGH = 0x06090031
    PARAMETER_INCOMPATIBLE = 0x06040043  #: general parameter incompatibility
    STORE_FAILED = 0x08000020  #: data cannot be transferred or stored to the application
    DEVICE_STATE = 0x08000022  #: data cannot be stored because of the present device state


#: every abort code of CiA 301's table, in its words
ABORT_TEXTS = {
    0x05030000: "toggle bit not alternated",
    0x05040000: "SDO protocol timed out",
    0x05040001: "client/server command specifier not valid or unknown",
    0x05040002: "invalid block size (block mode only)",
    0x05040003: "invalid sequence number (block mode only)",
    0x05040004: "CRC error (block mode only)",
    0x05040005: "out of memory",
    0x06010000: "unsupported access to an object",
    0x06010001: "attempt to read a write-only object",
    0x06010002: "attempt to write a read-only object",
    0x06020000: "object does not exist in the object dictionary",
    0x06040041: "object cannot be mapped to the PDO",
    0x06040042: "the number and length of the objects to be mapped would exceed the PDO length",
    0x06040043: "general parameter incompatibility",
    0x06040047: "general internal incompatibility in the device",
    0x06060000: "access failed due to a hardware error",
    0x06070010: "data type does not match, length of service parameter does not match",
    0x06070012: "data type does not match, length of service parameter too high",
    0x06070013: "data type does not match, length of service parameter too low",
    0x06090011: "sub-index does not exist",
    0x06090030: "invalid value for parameter (download only)",
    0x06090031: "value of parameter written too high (download only)",
    0x06090032: "value of parameter written too low (download only)",
    0x06090036: "maximum value is less than minimum value",
    0x060A0023: "resource not available: SDO connection",
    0x08000000: "general error",
    0x08000020: "data cannot be transferred or stored to the application",
    0x08000021: "data cannot be transferred or stored to the application because of local control",
    0x08000022: "data cannot be transferred or stored to the application because of the present device state",
    0x08000023: "object dictionary dynamic generation fails or no object dictionary is present",
    0x08000024: "no data available",
}


def abort_text(code: int) -> str:
    """An SDO abort code in words (CiA 301).

    Parameters
    ----------
    code : int
        The abort code (32 bits).

    Returns
    -------
    str
        Its meaning; a code CiA 301 does not list is said to be so.
    """
    return ABORT_TEXTS.get(code, "an abort code CiA 301 does not list")
