"""``rig drive status``'s document, read by SDO with nothing written or moved: the drive's picture
(``rig.commission.picture``), its identity, state, mode, units and PDO mapping in force, and its
last EMCY."""

from __future__ import annotations

from typing import Any

from drivers.cia402 import Cia402Axis, power_state
from drivers.cia402_pdo import read_mapping
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.emcy import emcy_text
from drivers.maps.mode_names import mode_text
from rig.commission.picture import picture
from rig.commission.status import device_units

__all__ = ["drive_status"]


def drive_status(a: Cia402Axis) -> dict[str, Any]:
    """The drive's whole picture: identity, state with every statusword bit named, mode,
    actual values, limits, profile and ramps, windows, errors, inputs (``picture``), units
    and the PDO mapping in force. Moves nothing and needs no factor: where the drive gives
    none, its own units stand.

    Parameters
    ----------
    a : Cia402Axis
        The drive, its driver not set up.

    Returns
    -------
    dict[str, Any]
        The picture.
    """
    units = a.discover(check_mode=False)
    word = int(a.sdo_read(cia.STATUSWORD))
    od = a.node.object_dictionary
    mapping = {}
    for receive in (True, False):
        for pdo in read_mapping(a.sdo_read, od, receive=receive):
            mapping[pdo.name] = {
                "valid": pdo.valid,
                "cob_id": f"0x{pdo.cob_id:03X}",
                "type": pdo.ttype,
                "entries": [f"0x{e.wire(a.axis_number):04X}:{e.subindex:02X}/{e.bits}" for e in pdo.entries],
            }
    mode = a.discovery.optional(cia.MODES_DISPLAY)
    bits = a.discovery.optional(cia.SUPPORTED_MODES)
    seen = picture(a, units, word, None if mode is None else int(mode))
    return {
        "node": a.node_id,
        "axis": a.axis_number,
        "identity": {k: f"0x{v:08X}" for k, v in a.device_id.as_dict().items()},
        "vendor_name": a.device_id.vendor_name,
        "state": power_state(word).value,
        "statusword": f"0x{word:04X}",
        "statusword_bits": [b["name"] for b in seen["bits"] if b["set"]],
        "mode": mode,
        "mode_name": "not readable (0x6061)" if mode is None else mode_text(mode, toolkit=a.toolkit_drive),
        "supported_modes": sorted(Mode(m).name for m in a.discovery.supported_modes or ()),
        "modes_offered": a.discovery.offered(bits),
        "error_code": a.fault_text(),
        "last_emcy": a.watch.emcy_log[-1] if a.watch.emcy_log else _last_error(a),
        "units": units.describe() | device_units(units),
        "pdo_mapping": mapping,
        **seen,
    }


def _last_error(a: Cia402Axis) -> str | None:
    """The newest entry of the drive's error history (0x1003:01) in words, where it keeps one."""
    count = a.discovery.optional(cia.ERROR_HISTORY, 0)
    if not count:
        return None
    entry = a.discovery.optional(cia.ERROR_HISTORY, 1)
    if entry is None:
        return None
    code = int(entry) & 0xFFFF
    words = emcy_text(code, a.emcy_texts)
    return f"EMCY 0x{code:04X} ({words}), the newest of 0x1003 (the drive's error history)"
