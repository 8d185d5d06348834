"""An independent CiA 402 device for the driver's tests, written without drive-rig's code.

Nothing here imports ``drivers`` or ``plant_emulator``: the device reads a dictionary file of
``tests/drivers/dictionaries`` (TOML, this folder's own format, see its README), answers on
python-can's ``virtual`` bus as a CiA 301/402 node does, and keeps a log of every SDO
download, every SDO upload and every RPDO it receives, so a test can say exactly what the
host wrote. ``Dictionary.eds()`` writes the CiA 306 EDS the host is given, with the access
types the dictionary declares (or, with ``eds_access``, the ones a faulty EDS claims).

The device follows CiA 301 and CiA 402 as the standards write them, in this file's own words:

- SDO server (CiA 301 7.2.4.3): expedited and segmented download and upload; block transfer
  is refused (0x05040001). Aborts: 0x06020000 object missing, 0x06090011 sub-index missing,
  0x06010001 upload of a write-only entry, 0x06010002 download to a read-only or constant
  one, 0x06070010 length mismatch, 0x06090030 a value out of the entry's range (a mode the
  device does not have), 0x06040041/42/43 for a PDO mapping it cannot take,
  0x08000022 for a mapping changed while its PDO is valid.
- NMT (CiA 301 7.2.8): start, stop, pre-operational, resets; PDOs only in OPERATIONAL.
- PDOs: an RPDO on a valid COB-ID is logged and its mapped entries written (in OPERATIONAL);
  on SYNC every valid synchronous TPDO (type 0-240) is sent with its mapped values. With
  ``[pdo] preop_only`` a PDO parameter written outside PRE-OPERATIONAL, or a communication
  parameter other than the COB-ID while the PDO is valid, is refused (0x08000022).

``tests/drivers/fake_socketcand.py`` serves it in a process of its own, behind a socketcand server.
- CiA 402 (6.2): the power state machine on the controlword; 0x6061 follows 0x6060 when the
  mode is one of ``[device] modes``; profile position (new set-point, acknowledge, target
  reached; ``[motion] pp_short_by`` increments short of the target), profile velocity (at its
  target at once on an SDO write of 0x60FF, and on each SYNC), homing,
  cyclic synchronous position and velocity, each in the simplest form that shows the state.
"""

from __future__ import annotations

import pathlib
import struct
import threading
from dataclasses import dataclass, field
from typing import Any

import can
import tomllib

HERE = pathlib.Path(__file__).resolve().parent / "dictionaries"

#: type name -> (CiA 301 data type code, struct format; None for a string)
TYPES: dict[str, tuple[int, str | None]] = {
    "i8": (0x0002, "<b"),
    "i16": (0x0003, "<h"),
    "i32": (0x0004, "<i"),
    "u8": (0x0005, "<B"),
    "u16": (0x0006, "<H"),
    "u32": (0x0007, "<I"),
    "real32": (0x0008, "<f"),
    "str": (0x0009, None),
}
ACCESS = ("ro", "wo", "rw", "const")

ABORT_TEXT = {
    0x05040001: "command specifier not valid",
    0x06010001: "read of a write-only object",
    0x06010002: "write to a read-only object",
    0x06020000: "object does not exist",
    0x06040041: "object cannot be mapped",
    0x06040042: "mapping exceeds the PDO length",
    0x06040043: "general parameter incompatibility",
    0x06070010: "length does not match",
    0x06090011: "sub-index does not exist",
    0x06090030: "value range exceeded",
    0x08000022: "not in the present device state",
}


class Abort(Exception):
    def __init__(self, code: int) -> None:
        super().__init__(f"0x{code:08X} {ABORT_TEXT.get(code, '')}")
        self.code = code


@dataclass
class Entry:
    name: str
    type: str
    access: str
    value: Any
    pdo: bool = False
    eds_access: str = ""  #: what the EDS claims ("" : the same as ``access``)

    @property
    def size(self) -> int:
        fmt = TYPES[self.type][1]
        return struct.calcsize(fmt) if fmt else len(str(self.value).encode())

    def encode(self, value: Any | None = None) -> bytes:
        v = self.value if value is None else value
        fmt = TYPES[self.type][1]
        return struct.pack(fmt, v) if fmt else str(v).encode()

    def decode(self, data: bytes) -> Any:
        fmt = TYPES[self.type][1]
        if fmt is None:
            return data.decode(errors="replace")
        if len(data) != struct.calcsize(fmt):
            raise Abort(0x06070010)
        return struct.unpack(fmt, data)[0]


def _key(text: str) -> tuple[int, int]:
    index, _, sub = text.partition(":")
    return int(index, 16), int(sub or "0", 0)


@dataclass
class Dictionary:
    """A device's object dictionary as its file describes it (see ``dictionaries/README.md``)."""

    name: str
    device: dict[str, Any]
    entries: dict[tuple[int, int], Entry] = field(default_factory=dict)
    records: dict[int, str] = field(default_factory=dict)  #: index -> name, for objects with subs
    pdo_preop_only: bool = False  #: ``[pdo] preop_only``: PDO parameters only in PRE-OPERATIONAL

    @classmethod
    def load(cls, name: str) -> Dictionary:
        path = HERE / f"{name}.toml"
        data = tomllib.loads(path.read_text())
        dev = data["device"]
        d = cls(name, dev)
        base = dev.get("include")
        common = tomllib.loads((HERE / base).read_text()) if base else {}
        d._add(common.get("objects", {}), common.get("records", {}))
        for text in dev.get("remove", []):
            index, sub = _key(text)
            for key in [k for k in d.entries if k[0] == index and (":" not in text or k[1] == sub)]:
                del d.entries[key]
        d._add(data.get("objects", {}), data.get("records", {}))
        d._identity()
        d._pdos(data.get("pdo") or common.get("pdo", {}))
        for index in {k[0] for k in d.entries if k[1] > 0}:
            d.records.setdefault(index, f"Object {index:04X}")
            subs = [k[1] for k in d.entries if k[0] == index]
            d.entries.setdefault((index, 0), Entry("Highest sub-index supported", "u8", "ro", max(subs)))
        for text, access in data.get("eds_access", {}).items():
            d.entries[_key(text)].eds_access = access
        return d

    def _add(self, objects: dict[str, Any], records: dict[str, str]) -> None:
        for text, spec in objects.items():
            e = Entry(
                spec["name"],
                spec["type"],
                spec.get("access", "rw"),
                spec.get("value", 0),
                spec.get("pdo", False),
            )
            assert e.type in TYPES and e.access in ACCESS, (text, spec)
            self.entries[_key(text)] = e
        for text, name in records.items():
            self.records[int(text, 16)] = name

    def _identity(self) -> None:
        dev = self.device
        self.entries[(0x1000, 0)] = Entry("Device type", "u32", "ro", dev["device_type"])
        self.records[0x1018] = "Identity object"
        for sub, (key, name) in enumerate(
            (
                ("vendor", "Vendor-ID"),
                ("product", "Product code"),
                ("revision", "Revision number"),
                ("serial", "Serial number"),
            ),
            start=1,
        ):
            if key in dev:
                self.entries[(0x1018, sub)] = Entry(name, "u32", "ro", dev[key])
        if "modes" in dev and dev.get("supported_modes") is not None:
            self.entries[(0x6502, 0)] = Entry("Supported drive modes", "u32", "ro", dev["supported_modes"])

    def _pdos(self, pdo: dict[str, Any]) -> None:
        """Communication (0x1400/0x1800 + n) and mapping (0x1600/0x1A00 + n) objects."""
        self.pdo_preop_only = bool(pdo.get("preop_only", False))
        node = int(self.device.get("node", 1))
        for kind, comm, mapping, base in (("rpdo", 0x1400, 0x1600, 0x200), ("tpdo", 0x1800, 0x1A00, 0x180)):
            for n, spec in enumerate(pdo.get(kind, [])):
                cob = spec.get("cob_id", base + 0x100 * n + node if n < 4 else 0)
                if not spec.get("valid", True):
                    cob |= 0x80000000
                comm_access = spec.get("comm_access", pdo.get("comm_access", "rw"))
                map_access = spec.get("map_access", pdo.get("map_access", "rw"))
                self.records[comm + n] = f"{kind.upper()} communication parameter {n + 1}"
                self.records[mapping + n] = f"{kind.upper()} mapping parameter {n + 1}"
                self.entries[(comm + n, 1)] = Entry("COB-ID", "u32", comm_access, cob)
                self.entries[(comm + n, 2)] = Entry(
                    "Transmission type", "u8", comm_access, spec.get("type", 255)
                )
                entries = [_map_value(t) for t in spec.get("map", [])]
                self.entries[(mapping + n, 0)] = Entry(
                    "Number of mapped objects", "u8", map_access, len(entries)
                )
                for sub in range(1, 9):
                    value = entries[sub - 1] if sub <= len(entries) else 0
                    self.entries[(mapping + n, sub)] = Entry(f"Mapped object {sub}", "u32", map_access, value)

    # --- the EDS the host reads -------------------------------------------------------------
    def eds(self) -> str:
        dev = self.device
        lines = [
            "[FileInfo]",
            f"FileName={self.name}.eds",
            "FileVersion=1",
            "EDSVersion=4.0",
            f"Description=test dictionary {self.name}",
            "",
            "[DeviceInfo]",
            f"VendorName={dev.get('vendor_name', '')}",
            f"VendorNumber=0x{dev.get('vendor', 0):08X}",
            f"ProductName={dev.get('product_name', self.name)}",
            f"ProductNumber=0x{dev.get('product', 0):08X}",
            "BaudRate_500=1",
            "SimpleBootUpSlave=1",
            "Granularity=8",
            "NrOfRXPDO=4",
            "NrOfTXPDO=4",
            "",
        ]
        indices = sorted({k[0] for k in self.entries})
        groups = {
            "MandatoryObjects": [i for i in indices if i in (0x1000, 0x1001, 0x1018)],
            "OptionalObjects": [
                i for i in indices if i not in (0x1000, 0x1001, 0x1018) and not 0x2000 <= i < 0x6000
            ],
            "ManufacturerObjects": [i for i in indices if 0x2000 <= i < 0x6000],
        }
        for section, members in groups.items():
            lines += [f"[{section}]", f"SupportedObjects={len(members)}"]
            lines += [f"{n}=0x{i:04X}" for n, i in enumerate(members, start=1)] + [""]
        for index in indices:
            if index in self.records:
                subs = sorted(k[1] for k in self.entries if k[0] == index)
                lines += [
                    f"[{index:04X}]",
                    f"ParameterName={self.records[index]}",
                    "ObjectType=0x9",
                    f"SubNumber={len(subs)}",
                    "",
                ]
                for sub in subs:
                    lines += [f"[{index:04X}sub{sub:X}]", *self._var(self.entries[(index, sub)]), ""]
            else:
                lines += [f"[{index:04X}]", *self._var(self.entries[(index, 0)]), ""]
        return "\n".join(lines) + "\n"

    @staticmethod
    def _var(e: Entry) -> list[str]:
        value = e.value if e.type != "real32" else struct.unpack("<I", struct.pack("<f", e.value))[0]
        shown = str(value) if e.type == "str" else (f"0x{value:X}" if value >= 0 else str(value))
        return [
            f"ParameterName={e.name}",
            "ObjectType=0x7",
            f"DataType=0x{TYPES[e.type][0]:04X}",
            f"AccessType={e.eds_access or e.access}",
            f"DefaultValue={shown}",
            f"PDOMapping={int(e.pdo)}",
        ]

    def write_eds(self, folder: pathlib.Path) -> pathlib.Path:
        path = folder / f"{self.name}.eds"
        path.write_text(self.eds())
        return path


def _map_value(text: str) -> int:
    """``"0x6040:0/16"`` -> a CiA 301 mapping entry (index << 16 | sub << 8 | bits)."""
    obj, _, bits = text.partition("/")
    index, sub = _key(obj)
    return index << 16 | sub << 8 | int(bits)


# --- the device ------------------------------------------------------------------------------
SW_STATES = {  # CiA 402 statusword bits 0-6 of each state (mask 0x6F or 0x4F)
    "SWITCH ON DISABLED": 0x40,
    "READY TO SWITCH ON": 0x21,
    "SWITCHED ON": 0x23,
    "OPERATION ENABLED": 0x27,
    "QUICK STOP ACTIVE": 0x07,
    "FAULT": 0x08,
}


class FakeDrive:
    """``dictionary`` served as node ``node`` on python-can's virtual bus ``channel``."""

    def __init__(
        self, dictionary: Dictionary, channel: str, node: int = 1, interface: str = "virtual"
    ) -> None:
        self.od = dictionary
        self.node = node
        self.nmt = "PRE-OPERATIONAL"
        self.state = "SWITCH ON DISABLED"
        self.downloads: list[tuple[int, int, Any, int | None]] = []  #: (index, sub, value, abort or None)
        self.uploads: list[tuple[int, int, int | None]] = []  #: (index, sub, abort or None)
        self.rpdos: list[tuple[int, bytes]] = []  #: (COB-ID, data) of every RPDO taken
        self.rpdo_writes: list[tuple[int, int, Any]] = []  #: (index, sub, value) an RPDO wrote
        self.nmt_log: list[tuple[int, int]] = []  #: (command, node) of every NMT frame
        self.syncs = 0
        #: SYNC count -> (COB-ID, data) a third node (another master) sends just before this
        #: device's TPDOs of that SYNC: the host receives it first, in the same cycle
        self.inject: dict[int, tuple[int, bytes]] = {}
        self._lock = threading.Lock()
        self._segment: dict[str, Any] | None = None
        self._last_cw = 0
        motion = dictionary.device.get("motion", {})
        self.pp_short_by = int(motion.get("pp_short_by", 0))
        self._status_extra = 0
        self._put(0x6041, 0, self._statusword())
        self.channel = channel
        self.bus = can.Bus(interface=interface, channel=channel, receive_own_messages=False)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name=f"fake-drive-{node}", daemon=True)
        self._thread.start()
        self._send(0x700 + node, b"\x00")  # boot-up

    # --- the log, for tests -------------------------------------------------------------------
    def writes(self) -> list[tuple[int, int, Any]]:
        """Every (index, sub, value) the host wrote: SDO downloads accepted or not, and RPDO entries."""
        with self._lock:
            return [(i, s, v) for i, s, v, _ in self.downloads] + list(self.rpdo_writes)

    def manufacturer_writes(self) -> list[tuple[int, int, Any]]:
        return [w for w in self.writes() if 0x2000 <= w[0] < 0x6000]

    def value(self, index: int, sub: int = 0) -> Any:
        return self.od.entries[(index, sub)].value

    def set_access(self, index: int, sub: int, access: str) -> None:
        """The device's own access (the EDS keeps what it said)."""
        e = self.od.entries[(index, sub)]
        e.eds_access = e.eds_access or e.access
        e.access = access

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.bus.shutdown()

    # --- the wire -------------------------------------------------------------------------------
    def _send(self, cob: int, data: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=cob, data=data, is_extended_id=False))

    def _serve(self) -> None:
        while not self._stop.is_set():
            msg = self.bus.recv(0.02)
            if msg is None or msg.is_error_frame or msg.is_remote_frame:
                continue
            with self._lock:
                self._frame(msg.arbitration_id, bytes(msg.data))

    def _frame(self, cob: int, data: bytes) -> None:
        if cob == 0x000 and len(data) == 2:
            self._nmt(data[0], data[1])
        elif cob == 0x600 + self.node and len(data) == 8 and self.nmt != "STOPPED":
            self._sdo(data)
        elif cob == (self._get(0x1005, 0) & 0x7FF if (0x1005, 0) in self.od.entries else 0x080):
            self._sync()
        elif self.nmt == "OPERATIONAL":
            self._rpdo(cob, data)

    def _nmt(self, command: int, node: int) -> None:
        self.nmt_log.append((command, node))
        if node not in (0, self.node):
            return
        self.nmt = {0x01: "OPERATIONAL", 0x02: "STOPPED", 0x80: "PRE-OPERATIONAL"}.get(command, self.nmt)
        if command in (0x81, 0x82):
            self.nmt = "PRE-OPERATIONAL"
            self._send(0x700 + self.node, b"\x00")

    # --- SDO server --------------------------------------------------------------------------
    def _sdo(self, req: bytes) -> None:
        ccs = req[0] >> 5
        index, sub = struct.unpack_from("<HB", req, 1)
        try:
            if ccs == 1:
                self._download(req, index, sub)
            elif ccs == 0 and self._segment and self._segment["kind"] == "down":
                self._download_segment(req)
            elif ccs == 2:
                self._upload(index, sub)
            elif ccs == 3 and self._segment and self._segment["kind"] == "up":
                self._upload_segment(req)
            elif ccs == 4:
                self._segment = None
            else:
                raise Abort(0x05040001)
        except Abort as exc:
            self._segment = None
            self._send(0x580 + self.node, struct.pack("<BHBI", 0x80, index, sub, exc.code))

    def _entry(self, index: int, sub: int) -> Entry:
        if not any(k[0] == index for k in self.od.entries):
            raise Abort(0x06020000)
        if (index, sub) not in self.od.entries:
            raise Abort(0x06090011)
        return self.od.entries[(index, sub)]

    def _download(self, req: bytes, index: int, sub: int) -> None:
        expedited, sized = req[0] & 0x02, req[0] & 0x01
        if not expedited:
            size = struct.unpack_from("<I", req, 4)[0] if sized else None
            self._entry(index, sub)  # a missing object aborts at once
            self._segment = {
                "kind": "down",
                "index": index,
                "sub": sub,
                "size": size,
                "data": b"",
                "toggle": 0,
            }
            self._send(0x580 + self.node, struct.pack("<BHBI", 0x60, index, sub, 0))
            return
        n = (req[0] >> 2) & 0x03 if sized else 0
        self._store(index, sub, req[4 : 8 - n])
        self._send(0x580 + self.node, struct.pack("<BHBI", 0x60, index, sub, 0))

    def _download_segment(self, req: bytes) -> None:
        seg = self._segment
        assert seg is not None
        toggle = (req[0] >> 4) & 1
        n = (req[0] >> 1) & 0x07
        seg["data"] += req[1 : 8 - n]
        self._send(0x580 + self.node, bytes([0x20 | toggle << 4]) + bytes(7))
        if req[0] & 0x01:
            self._segment = None
            self._store(seg["index"], seg["sub"], seg["data"])

    def _store(self, index: int, sub: int, data: bytes) -> None:
        """A download: logged, checked against the access and the type, then written."""
        try:
            e = self._entry(index, sub)
            value = e.decode(data) if TYPES[e.type][1] is None or len(data) >= e.size else None
            if value is None:
                raise Abort(0x06070010)
            if e.type != "str" and len(data) != e.size:
                raise Abort(0x06070010)
        except Abort as exc:
            self.downloads.append((index, sub, data.hex(), exc.code))
            raise
        if e.access in ("ro", "const"):
            self.downloads.append((index, sub, value, 0x06010002))
            raise Abort(0x06010002)
        try:
            self._write(index, sub, value, e)
        except Abort as exc:
            self.downloads.append((index, sub, value, exc.code))
            raise
        self.downloads.append((index, sub, value, None))

    def _upload(self, index: int, sub: int) -> None:
        try:
            e = self._entry(index, sub)
            if e.access == "wo":
                raise Abort(0x06010001)
        except Abort as exc:
            self.uploads.append((index, sub, exc.code))
            raise
        self.uploads.append((index, sub, None))
        data = e.encode()
        if len(data) <= 4:
            head = 0x43 | (4 - len(data)) << 2
            self._send(0x580 + self.node, struct.pack("<BHB", head, index, sub) + data.ljust(4, b"\x00"))
            return
        self._segment = {"kind": "up", "data": data, "toggle": 0}
        self._send(0x580 + self.node, struct.pack("<BHBI", 0x41, index, sub, len(data)))

    def _upload_segment(self, req: bytes) -> None:
        seg = self._segment
        assert seg is not None
        toggle = (req[0] >> 4) & 1
        chunk, seg["data"] = seg["data"][:7], seg["data"][7:]
        last = not seg["data"]
        head = toggle << 4 | (7 - len(chunk)) << 1 | int(last)
        self._send(0x580 + self.node, bytes([head]) + chunk.ljust(7, b"\x00"))
        if last:
            self._segment = None

    # --- what a write does ------------------------------------------------------------------
    def _get(self, index: int, sub: int = 0) -> Any:
        return self.od.entries[(index, sub)].value

    def _put(self, index: int, sub: int, value: Any) -> None:
        if (index, sub) in self.od.entries:
            self.od.entries[(index, sub)].value = value

    def _write(self, index: int, sub: int, value: Any, e: Entry) -> None:
        if 0x1400 <= index < 0x1C00 and self.od.pdo_preop_only:
            self._check_preop(index, sub)
        if 0x1600 <= index < 0x1800 or 0x1A00 <= index < 0x1C00:
            self._check_mapping(index, sub, value)
        if index == 0x6060 and value not in self.od.device.get("modes", []):
            raise Abort(0x06090030)
        e.value = value
        if index == 0x6060:
            self._put(0x6061, 0, value)
        if index == 0x60FF and self._mode() == 3 and self.state == "OPERATION ENABLED":
            self._put(0x606C, 0, value)  # profile velocity: at the target at once, SYNC or not
        elif index == 0x6040:
            self._controlword(value)

    def _check_preop(self, index: int, sub: int) -> None:
        """``[pdo] preop_only``: PDO parameters change only in PRE-OPERATIONAL, and a communication
        parameter other than the COB-ID only while the PDO is not valid (bit 31 set first)."""
        if self.nmt != "PRE-OPERATIONAL":
            raise Abort(0x08000022)
        comm = index if index in (*range(0x1400, 0x1600), *range(0x1800, 0x1A00)) else None
        if comm is not None and sub != 1 and not self._get(comm, 1) & 0x80000000:
            raise Abort(0x08000022)

    def _check_mapping(self, index: int, sub: int, value: int) -> None:
        comm = index - 0x200
        if not self._get(comm, 1) & 0x80000000:
            raise Abort(0x08000022)  # CiA 301: a mapping changes only while its PDO is not valid
        if sub == 0:
            entries = [self._get(index, s) for s in range(1, value + 1)] if value <= 8 else None
            if entries is None:
                raise Abort(0x06090030)
            if sum(m & 0xFF for m in entries) > 64:
                raise Abort(0x06040042)
            return
        if self._get(index, 0) != 0:
            raise Abort(0x06040043)
        target = self.od.entries.get((value >> 16, (value >> 8) & 0xFF))
        if value and (target is None or not target.pdo or target.size * 8 != value & 0xFF):
            raise Abort(0x06040041)

    # --- PDOs ---------------------------------------------------------------------------------
    def _pdo_list(self, comm_base: int) -> list[tuple[int, int, list[int]]]:
        """(COB-ID, type, mapping entries) of each valid PDO."""
        out = []
        for n in range(512):
            if (comm_base + n, 1) not in self.od.entries:
                continue
            cob = self._get(comm_base + n, 1)
            if cob & 0x80000000:
                continue
            mapping = comm_base + 0x200 + n
            count = self._get(mapping, 0)
            out.append(
                (
                    cob & 0x7FF,
                    self._get(comm_base + n, 2),
                    [self._get(mapping, s) for s in range(1, count + 1)],
                )
            )
        return out

    def _rpdo(self, cob: int, data: bytes) -> None:
        for pdo_cob, _ttype, mapping in self._pdo_list(0x1400):
            if pdo_cob != cob:
                continue
            self.rpdos.append((cob, data))
            offset = 0
            for m in mapping:
                index, sub, bits = m >> 16, (m >> 8) & 0xFF, m & 0xFF
                e = self.od.entries[(index, sub)]
                value = e.decode(data[offset : offset + bits // 8])
                offset += bits // 8
                self.rpdo_writes.append((index, sub, value))
                e.value = value
                if index == 0x6040:
                    self._controlword(value)

    def _sync(self) -> None:
        self.syncs += 1
        if self.syncs in self.inject:
            cob, data = self.inject.pop(self.syncs)
            with can.Bus(interface="virtual", channel=self.channel) as other:
                other.send(can.Message(arbitration_id=cob, data=data, is_extended_id=False))
        self._cyclic()
        if self.nmt != "OPERATIONAL":
            return
        for cob, ttype, mapping in self._pdo_list(0x1800):
            if ttype > 240 or (ttype and self.syncs % ttype):
                continue
            data = b"".join(self.od.entries[(m >> 16, (m >> 8) & 0xFF)].encode() for m in mapping)
            self._send(cob, data)

    # --- CiA 402 ------------------------------------------------------------------------------
    def _statusword(self) -> int:
        return (
            SW_STATES[self.state]
            | 0x0200
            | (0x10 if self.state != "SWITCH ON DISABLED" else 0)
            | self._status_extra
        )

    def _controlword(self, cw: int) -> None:
        rising, self._last_cw = cw & ~self._last_cw, cw
        s = self.state
        if s == "FAULT":
            if rising & 0x80:
                self.state = "SWITCH ON DISABLED"
        elif cw & 0x02 == 0:  # disable voltage
            self.state = "SWITCH ON DISABLED"
        elif cw & 0x06 == 0x02:  # quick stop: at rest at once, then switch on disabled (option 2)
            self.state = "SWITCH ON DISABLED" if s != "SWITCH ON DISABLED" else s
            self._put(0x606C, 0, 0)
        elif cw & 0x87 == 0x06:
            self.state = "READY TO SWITCH ON"
        elif cw & 0x8F == 0x07 and s in ("READY TO SWITCH ON", "OPERATION ENABLED"):
            self.state = "SWITCHED ON"
        elif cw & 0x8F == 0x0F and s in ("SWITCHED ON", "OPERATION ENABLED"):
            self.state = "OPERATION ENABLED"
            if s != "OPERATION ENABLED":
                self._status_extra = 0
            elif rising & 0x10:
                self._set_point()
        if cw & 0x10 == 0:
            self._status_extra &= ~0x1000
        self._put(0x6041, 0, self._statusword())

    def _mode(self) -> int:
        return int(self._get(0x6061)) if (0x6061, 0) in self.od.entries else 0

    def _set_point(self) -> None:
        """New set-point (bit 4 rising) in profile position or homing: done at once."""
        if self._mode() == 1:
            target = int(self._get(0x607A))
            here = int(self._get(0x6064))
            step = self.pp_short_by if target > here else -self.pp_short_by
            self._put(0x6064, 0, target - step)
        elif self._mode() == 6:
            self._put(0x6064, 0, 0)
        self._status_extra |= 0x1000 | 0x0400

    def _cyclic(self) -> None:
        """On SYNC: cyclic synchronous position and velocity, profile velocity (1 ms a SYNC)."""
        if self.state != "OPERATION ENABLED":
            return
        mode = self._mode()
        if mode == 8 and (0x607A, 0) in self.od.entries:
            target = int(self._get(0x607A))
            if (0x606C, 0) in self.od.entries:  # the speed of that step (1 ms a SYNC), as a drive reports it
                self._put(0x606C, 0, (target - int(self._get(0x6064))) * 1000)
            self._put(0x6064, 0, target)
        elif mode in (3, 9) and (0x60FF, 0) in self.od.entries:
            v = int(self._get(0x60FF))
            self._put(0x606C, 0, v)
            if (0x6064, 0) in self.od.entries:  # a speed controller may have no position
                self._put(0x6064, 0, int(self._get(0x6064)) + v // 1000)
        self._put(0x6041, 0, self._statusword())
