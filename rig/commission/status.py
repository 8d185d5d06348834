"""``rig drive status`` for a person: what the drive is, how it is set up, in its own units where
it gives no factor to SI, and which ``--units`` key would give SI.

``device_units`` says each quantity's unit in words (added to the status's ``units``);
``status_lines`` is the text report: state and mode by name, identity in hex, units, the PDO
mapping in force as a table, the last EMCY in words.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from drivers.cia402_units import DriveUnits
from drivers.identity import Identity
from rig.commission.picture import SECTIONS

__all__ = ["UNITS_HINT", "device_units", "object_lines", "picture_lines", "status_lines"]

UNITS_HINT = "--units {key}=VALUE"  #: how ``rig drive`` is given a unit the drive lacks


def device_units(units: DriveUnits) -> dict[str, str]:
    """Each quantity's unit in words: the factor to SI and where it came from, or the drive's own
    unit and the ``--units`` key that would give SI.

    Parameters
    ----------
    units : drivers.cia402_units.DriveUnits
        The drive's units.

    Returns
    -------
    dict[str, str]
        Quantity -> its unit in words.
    """
    src = units.source

    def factor(value: float, per: str, where: str) -> str:
        return f"{value:.6g} drive units per {per} (from {where})"

    def given(key: str) -> str:
        return UNITS_HINT.format(key=key).replace("VALUE", "N")

    position = (
        factor(units.position, "rad", src.get("position", "?"))
        if math.isfinite(units.position)
        else f"the drive's increments (no 0x608F, 0x60A8 or 0x6092; {given('counts_per_rev')} gives rad)"
    )
    velocity = (
        factor(units.velocity, "rad/s", src.get("velocity", "?"))
        if math.isfinite(units.velocity)
        else f"the drive's velocity unit (no factor; {given('counts_per_rev')} gives rad/s)"
    )
    torque = (
        f"per mille of {units.rated_torque:g} N m (from {src.get('rated_torque') or '?'})"
        if math.isfinite(units.rated_torque)
        else f"per mille of the rated torque (no 0x6076; {given('rated_torque')} in N m gives N m)"
    )
    current = (
        f"per mille of {units.rated_current:g} A (from {src.get('rated_current') or '?'})"
        if math.isfinite(units.rated_current)
        else f"per mille of the rated current (no 0x6075; {given('rated_current')} in A gives A)"
    )
    return {
        "position_unit": position,
        "velocity_unit": velocity,
        "torque_unit": torque,
        "current_unit": current,
    }


def status_lines(status: dict[str, Any], name_of: Callable[[int, int], str]) -> list[str]:
    """The status report (``DriveTool.status``); ``name_of(index, sub)`` an object's EDS name.

    Parameters
    ----------
    status : dict[str, Any]
        ``DriveTool.status``'s.
    name_of : Callable[[int, int], str]
        ``name_of(index, sub)``.

    Returns
    -------
    list[str]
        The lines.
    """
    ids = {k: int(v, 16) for k, v in status["identity"].items()}
    identity = Identity(**ids, vendor_name=status.get("vendor_name") or "").text()
    bits = ", ".join(status["statusword_bits"]) or "none"
    u = status["units"]
    rows = [
        ("node", str(status["node"]) + (f", axis {status['axis']}" if status.get("axis", 1) > 1 else "")),
        ("identity", identity),
        ("state", f"{status['state']} (statusword {status['statusword']}: {bits})"),
        ("mode", f"{status['mode_name']} (0x6061 = {status['mode']})"),
        ("modes offered", status["modes_offered"]),
        ("error code", status["error_code"]),
        ("last EMCY", status["last_emcy"] or "none since the drive was reached"),
        ("position unit", u["position_unit"]),
        ("velocity unit", u["velocity_unit"]),
        ("torque unit", u["torque_unit"]),
        ("current unit", u["current_unit"]),
    ]
    lines = [f"{key:15s} {text}" for key, text in rows]
    lines.append("PDO mapping in force:")
    lines.append(f"  {'PDO':6s} {'COB-ID':7s} {'valid':6s} {'type':5s} entries")
    for pdo, m in status["pdo_mapping"].items():
        entries = []
        for text in m["entries"]:
            obj, _, size = text.partition("/")
            index, _, sub = obj.partition(":")
            name = name_of(int(index, 16), int(sub, 16))
            entries.append(f"{obj} {name} ({size} bit)" if name else f"{obj} ({size} bit)")
        valid = "yes" if m["valid"] else "no"
        lines.append(f"  {pdo:6s} {m['cob_id']:7s} {valid:6s} {m['type']!s:5s} {', '.join(entries) or '-'}")
    return lines + picture_lines(status)


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.6g}"


def picture_lines(status: dict[str, Any]) -> list[str]:
    """The rest of the picture (``rig.commission.picture``): who it is, every statusword bit, the
    quantities in a table (SI value, its unit, the drive's number and unit), errors, inputs.

    Parameters
    ----------
    status : dict[str, Any]
        ``DriveTool.status``'s.

    Returns
    -------
    list[str]
        The lines.
    """
    lines = []
    strings = [f"{k} {status[k]}" for k in ("device_name", "hardware", "firmware") if status.get(k)]
    if strings:
        lines.append(f"{'device':15s} " + "; ".join(s.replace("_", " ") for s in strings))
    lines.append("statusword bits:")
    for b in status.get("bits", []):
        lines.append(f"  bit {b['bit']:2d}  {'1' if b['set'] else '0'}  {b['name']}")
    for section, _rows in SECTIONS:
        values = status.get(section) or {}
        if not values:
            continue
        lines.append(f"{section}:")
        lines.append(f"  {'':34s} {'value':>12s} {'unit':8s} drive value")
        for name, q in values.items():
            lines.append(
                f"  {name:34s} {_number(q['value']):>12s} {q['unit']:8s} {q['drive_value']} {q['drive_unit']}"
            )
    if status.get("error_register") is not None:
        lines.append(f"{'error register':15s} {status['error_register']} (0x1001)")
    history = status.get("error_history") or []
    lines.append(
        f"{'error history':15s} "
        + ("; ".join(f"{h['code']} {h['text']}" for h in history) if history else "none kept (0x1003)")
    )
    inputs = status.get("digital_inputs")
    if inputs is not None:
        lines.append(
            f"{'inputs':15s} {inputs['raw']} (0x60FD): {', '.join(inputs['active']) or 'none active'}"
        )
    return lines


def object_lines(read: dict[str, Any]) -> list[str]:
    """``sdo read``'s report: the object, its name, type and access, its value in decimal and hex,
    and the quantity it holds in SI and the drive's units (``DriveTool.read_object``).

    Parameters
    ----------
    read : dict[str, Any]
        ``DriveTool.read_object``'s.

    Returns
    -------
    list[str]
        The lines.
    """
    what = ", ".join(x for x in (read.get("type"), read.get("access")) if x)
    lines = [
        f"{'object':15s} {read['object']}  {read.get('name') or '(not in the EDS)'}"
        + (f" ({what})" if what else "")
    ]
    value = read["value"]
    lines.append(f"{'value':15s} {value}" + (f" ({read['hex']})" if "hex" in read else ""))
    q = read.get("quantity")
    if q is not None:
        si = "-" if q["value"] is None else f"{q['value']:.6g} {q['unit']}"
        lines.append(f"{'means':15s} {si} ({q['drive_value']} {q['drive_unit']})")
    return lines
