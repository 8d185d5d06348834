"""CANopen vendor-IDs (CiA 301 0x1018:01, assigned by CAN in Automation) and their holders' names,
for what a status or a scan prints beside the number.

Written from each vendor's own public material as the test dictionaries (tests/drivers/
dictionaries) and the zoo's twins (plant_emulator/devices) cite it, or a vendor's manual that
states its id (a number only where a source gives it). A number not here is printed in hex
alone, never guessed.
"""

from __future__ import annotations

__all__ = ["VENDORS", "vendor_of"]

VENDORS: dict[int, str] = {
    0x00000002: "Beckhoff Automation",
    0x00000028: "Moog",
    0x00000055: "Axiomatic Technologies",
    0x0000006A: "Kollmorgen",
    0x0000009A: "Elmo Motion Control",
    0x000000AB: "Copley Controls",
    0x000000FB: "maxon motor ag",
    0x00000117: "JVL Industri Elektronik",
    0x00000147: "Dr. Fritz Faulhaber GmbH & Co. KG",
    0x000001A3: "Technosoft",
    0x0000026C: "Nanotec Electronic GmbH & Co. KG",
    0x00000286: "TRINAMIC Motion Control GmbH & Co. KG",
    0x0000029C: "Ingenia Motion Control",
    0x0000036A: "WITTENSTEIN",
    0x00000DB1: "drive-rig",
    0x5A65726F: "ZeroErr",
}


def vendor_of(vendor_id: int | None) -> str:
    """The name of a vendor ID's holder.

    Parameters
    ----------
    vendor_id : int or None
        The vendor ID (0x1018 sub 1).

    Returns
    -------
    str
        The holder's name, "" where the ID is not in ``VENDORS`` or None.
    """
    return VENDORS.get(vendor_id, "") if vendor_id is not None else ""
