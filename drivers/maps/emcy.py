"""Emergency error codes in words: CiA 301's classes and CiA 402's drive codes, and a device's own.

``emcy_text(code, device)`` looks the code up in ``device`` (a drive's own table, e.g. the
``[emcy]`` of its device profile) first, then in the generic table below by the code itself,
then by its class (the code with its last one, two or three hex digits cleared), so every
code gets the most specific text anyone gives. The texts are written here from the code
classes the standards define.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["GENERIC", "emcy_text"]

#: generic codes (CiA 301 Table 21, CiA 402 error codes)
GENERIC: dict[int, str] = {
    0x0000: "no error (error reset)",
    0x1000: "generic error",
    0x2000: "current",
    0x2100: "current, device input side",
    0x2200: "current inside the device",
    0x2300: "current, device output side",
    0x2310: "continuous over-current",
    0x2320: "short circuit or earth leakage",
    0x3000: "voltage",
    0x3100: "mains voltage",
    0x3200: "voltage inside the device",
    0x3210: "DC link over-voltage",
    0x3220: "DC link under-voltage",
    0x3300: "output voltage",
    0x4000: "temperature",
    0x4100: "ambient temperature",
    0x4200: "device temperature",
    0x4210: "excess temperature of the device",
    0x4300: "drive temperature",
    0x4310: "excess temperature of the drive (motor)",
    0x5000: "device hardware",
    0x6000: "device software",
    0x6100: "internal software",
    0x6200: "user software",
    0x6300: "data set",
    0x7000: "additional modules",
    0x7100: "power",
    0x7300: "sensor",
    0x7303: "resolver 1 fault",
    0x7305: "incremental sensor 1 fault",
    0x7500: "communication (additional module)",
    0x8000: "monitoring",
    0x8100: "communication",
    0x8110: "CAN overrun (objects lost)",
    0x8120: "CAN in error passive mode",
    0x8130: "life guard error or heartbeat error",
    0x8140: "recovered from bus off",
    0x8150: "CAN-ID collision",
    0x8200: "protocol error",
    0x8210: "PDO not processed due to length error",
    0x8220: "PDO length exceeded",
    0x8230: "DAM MPDO not processed, destination object not available",
    0x8240: "unexpected SYNC data length",
    0x8250: "RPDO timeout",
    0x8300: "torque control",
    0x8311: "excess torque",
    0x8400: "velocity speed controller",
    0x8500: "position controller",
    0x8600: "positioning controller",
    0x8611: "following error",
    0x8612: "reference limit",
    0x8700: "sync controller",
    0x8800: "winding controller",
    0x9000: "external error",
    0xF000: "additional functions",
    0xFF00: "device specific",
}


def emcy_text(code: int, device: Mapping[int, str] | None = None) -> str:
    """An EMCY error code in words (see the module docstring).

    Parameters
    ----------
    code : int
        The EMCY error code (CiA 301, 16 bits).
    device : Mapping[int, str], optional
        The device's own texts by code, tried first.

    Returns
    -------
    str
        The device's text, else the most specific generic one.
    """
    if device and code in device:
        return device[code]
    for mask in (0xFFFF, 0xFFF0, 0xFF00, 0xF000):
        text = GENERIC.get(code & mask)
        if text is not None:
            return text
    return "unknown"
