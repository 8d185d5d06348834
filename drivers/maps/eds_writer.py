"""Writing an EDS (CiA 306) from a table of objects: the toolkit's own files and the emulator's zoo.

A table is a list of ``Obj``: a VAR (``var``), or a RECORD/ARRAY of ``Var`` entries
(``record``); ``pdo_comm``/``pdo_map`` make the PDO parameter records. ``eds_text``
gives the file's text, sections in CiA 306 order, with the [DeviceInfo] of
``DeviceInfo`` and the PDO counts taken from the table.

The table's parts are in ``drivers.maps.eds_table`` (the objects, the data types, [DeviceInfo])
and ``drivers.maps.cia301_table`` (the CiA 301 objects, the PDO records), and exported here too.
"""

from __future__ import annotations

from collections.abc import Sequence

from drivers.maps.cia301_table import cia301_objects, pdo_comm, pdo_map, pdo_objects, store_objects
from drivers.maps.eds_table import (
    BOOLEAN,
    INT8,
    INT16,
    INT32,
    UINT8,
    UINT16,
    UINT32,
    VSTRING,
    DeviceInfo,
    Obj,
    Var,
    mapped,
    record,
    var,
)

__all__ = [
    "BOOLEAN",
    "INT8",
    "INT16",
    "INT32",
    "UINT8",
    "UINT16",
    "UINT32",
    "VSTRING",
    "DeviceInfo",
    "Obj",
    "Var",
    "cia301_objects",
    "eds_text",
    "mapped",
    "pdo_comm",
    "pdo_map",
    "pdo_objects",
    "record",
    "store_objects",
    "var",
]


def eds_text(objs: Sequence[Obj], file_name: str, info: DeviceInfo) -> str:
    """The EDS (CiA 306) text of ``objs``.

    Parameters
    ----------
    objs : Sequence[Obj]
        The objects.
    file_name : str
        The FileInfo's FileName.
    info : DeviceInfo
        Its [DeviceInfo].

    Returns
    -------
    str
        The EDS text.
    """
    return "\n".join([*_info_lines(objs, file_name, info), *_lists(objs), *_object_lines(objs)])


def _info_lines(objs: Sequence[Obj], file_name: str, info: DeviceInfo) -> list[str]:
    """[FileInfo] and [DeviceInfo], the PDO counts taken from ``objs``."""
    rpdos = sum(1 for o in objs if 0x1400 <= o.index < 0x1600)
    tpdos = sum(1 for o in objs if 0x1800 <= o.index < 0x1A00)
    return [
        "[FileInfo]",
        f"FileName={file_name}",
        "FileVersion=1",
        "FileRevision=0",
        "EDSVersion=4.0",
        f"Description={info.description}",
        "CreatedBy=drive-rig",
        "",
        "[DeviceInfo]",
        f"VendorName={info.vendor_name}",
        f"VendorNumber=0x{info.vendor_number:08X}",
        f"ProductName={info.product_name}",
        f"ProductNumber=0x{info.product_number:08X}",
        *(f"BaudRate_{rate}=1" for rate in info.baud_rates),
        "SimpleBootUpSlave=1",
        "Granularity=8",
        f"NrOfRXPDO={rpdos}",
        f"NrOfTXPDO={tpdos}",
        f"LSS_Supported={int(info.lss)}",
        "",
    ]


def _lists(objs: Sequence[Obj]) -> list[str]:
    """[MandatoryObjects], [OptionalObjects] and [ManufacturerObjects]: the indices of each."""
    out = []
    mandatory = (0x1000, 0x1001, 0x1018)
    groups = {
        "MandatoryObjects": [o for o in objs if o.index in mandatory],
        "OptionalObjects": [o for o in objs if o.index not in mandatory and not 0x2000 <= o.index < 0x6000],
        "ManufacturerObjects": [o for o in objs if 0x2000 <= o.index < 0x6000],
    }
    for section, members in groups.items():
        out.append(f"[{section}]")
        out.append(f"SupportedObjects={len(members)}")
        out += [f"{n + 1}=0x{o.index:04X}" for n, o in enumerate(members)]
        out.append("")
    return out


def _object_lines(objs: Sequence[Obj]) -> list[str]:
    """Each object's section by index, a RECORD's or ARRAY's followed by one per entry."""
    out = []
    for o in sorted(objs, key=lambda o: o.index):
        if o.kind == 0x7:
            out += [f"[{o.index:04X}]", *_var_lines(o.subs[0][1]), ""]
            continue
        out += [f"[{o.index:04X}]", f"ParameterName={o.name}", f"ObjectType=0x{o.kind:X}"]
        out += [f"SubNumber={len(o.subs)}", ""]
        for sub, v in o.subs:
            out += [f"[{o.index:04X}sub{sub:X}]", *_var_lines(v), ""]
    return out


def _var_lines(v: Var) -> list[str]:
    return [
        f"ParameterName={v.name}",
        "ObjectType=0x7",
        f"DataType=0x{v.data_type:04X}",
        f"AccessType={v.access}",
        f"DefaultValue={v.default}",
        f"PDOMapping={int(v.pdo)}",
    ]
