"""Conformance of every zoo drive, checked by code that did not write it: canopen's RemoteNode.

Each shipped profile's twin runs on an in-process bus; the peer is a plain canopen
``RemoteNode`` built from the profile's EDS, which this test reads itself (as Windows-1252,
a superset of ASCII: one EDS is cp1252, as its vendor's is). Expected values come from the
EDS as canopen parsed it, from CiA 301/402, or are written out here, never from the
emulator's or the driver's code.
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterator

import canopen
import pytest
from canopen.sdo import SdoAbortedError

from drivers.maps.cia import PowerState as S
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.device_profile import DeviceProfile, load_profile, zoo
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.presets import build_twin
from tests.plant_emulator.test_canopen_devices import statusword_state

PROFILES = sorted(zoo())
NODE = 5


def _od(profile: DeviceProfile) -> canopen.ObjectDictionary:
    source = io.StringIO(profile.eds.read_bytes().decode("cp1252"))
    source.name = profile.eds.name
    return canopen.import_od(source, NODE)


class Twin:
    """A zoo drive (node 5) on an in-process bus, a RemoteNode on its EDS, and the frames seen."""

    def __init__(self, name: str) -> None:
        self.profile = load_profile(zoo()[name])
        self.hub = SyncHub()
        self.host, self.devices = canopen.Network(), canopen.Network()
        attach_network(self.host, self.hub.bus(queue=False, channel="host"))
        attach_network(self.devices, self.hub.bus(queue=False, channel="device"))
        self.frames: list[tuple[int, bytes]] = []
        self.hub.taps.append(lambda m: self.frames.append((m.arbitration_id, bytes(m.data))))
        devices, self.period = build_twin(self.profile, self.devices, node_id=NODE)
        drive = devices[0]
        assert isinstance(drive, EmulatedDrive)
        self.drive = drive
        self.od = _od(self.profile)
        self.node = canopen.RemoteNode(NODE, self.od)
        self.host.add_node(self.node)
        drive.boot()
        self.syncs = 0

    def run(self, seconds: float) -> None:
        for _ in range(max(1, round(seconds / self.period))):
            self.syncs += 1
            self.hub.clock = self.syncs * self.period
            self.host.send_message(0x80, b"")

    def modes(self) -> list[int]:
        bits = self.node.sdo[0x6502].raw if 0x6502 in self.od else 0
        return [m for m, bit in ((1, 0), (3, 2), (6, 5), (7, 6), (8, 7), (9, 8), (10, 9)) if bits >> bit & 1]

    def per_rad_s(self) -> float:
        """Velocity units per rad/s, from the drive's unit objects as CiA 402 defines them."""
        node = self.node
        increments = (
            node.sdo[0x608F][1].raw / node.sdo[0x608F][2].raw
            if 0x608F in self.od
            else self.profile.units.counts_per_rev
        )
        if 0x60A9 in self.od:
            code = node.sdo[0x60A9].raw
            assert code == 0x00B44700, hex(code)  # the zoo's only velocity unit: rpm
            return 60.0 / (2 * math.pi)
        if 0x6092 in self.od:
            return node.sdo[0x6092][1].raw / node.sdo[0x6092][2].raw / (2 * math.pi)
        return increments / (2 * math.pi)

    def per_rad(self) -> float:
        """Position units per rad, from the drive's unit objects as CiA 402 defines them."""
        node = self.node
        if 0x60A8 in self.od:
            code = node.sdo[0x60A8].raw
            assert code == 0xFF410000, hex(code)  # the zoo's only position unit: 0.1 degree
            return 3600.0 / (2 * math.pi)
        if 0x6092 in self.od:
            return node.sdo[0x6092][1].raw / node.sdo[0x6092][2].raw / (2 * math.pi)
        if 0x608F in self.od:
            return node.sdo[0x608F][1].raw / node.sdo[0x608F][2].raw / (2 * math.pi)
        return self.profile.units.counts_per_rev / (2 * math.pi)

    def enable(self, mode: int) -> None:
        """OPERATIONAL, ``mode``, enabled."""
        self.node.nmt.state = "OPERATIONAL"
        self.node.sdo[0x6060].raw = mode
        self.run(self.profile.timing.mode_switch + 2 * self.period)
        for cw in (0x06, 0x07, 0x0F):
            self.node.sdo[0x6040].raw = cw
        assert self.state() is S.OPERATION_ENABLED

    def enable_csv(self, speed: float) -> None:
        """OPERATIONAL, CSV, enabled, at ``speed`` [rad/s]."""
        self.node.nmt.state = "OPERATIONAL"
        self.node.sdo[0x6060].raw = 9
        self.run(self.profile.timing.mode_switch + 2 * self.period)
        for cw in (0x06, 0x07, 0x0F):
            self.node.sdo[0x6040].raw = cw
        assert self.state() is S.OPERATION_ENABLED
        self.node.sdo[0x60FF].raw = round(speed * self.per_rad_s())

    def state(self) -> S:
        return statusword_state(self.node.sdo[0x6041].raw)

    def close(self) -> None:
        for net in (self.host, self.devices):
            net.bus.shutdown()


@pytest.fixture(params=PROFILES)
def twin(request: pytest.FixtureRequest) -> Iterator[Twin]:
    t = Twin(request.param)
    yield t
    t.close()


def _abort(fn) -> int:  # type: ignore[no-untyped-def]
    with pytest.raises(SdoAbortedError) as err:
        fn()
    return int(err.value.code)


def test_boot_up_identity_and_device_type(twin: Twin) -> None:
    assert (0x700 + NODE, b"\x00") in twin.frames  # boot-up: one byte 0x00
    node, od = twin.node, twin.od
    assert node.sdo[0x1000].raw == od[0x1000].default
    assert node.sdo[0x1000].raw & 0xFFFF == 402
    for sub in (1, 2):
        assert node.sdo[0x1018][sub].raw == od[0x1018][sub].default
    assert node.sdo[0x6041].raw & 0x4F == 0x40  # SWITCH ON DISABLED after boot


def test_sdo_abort_codes(twin: Twin) -> None:
    node = twin.node
    assert _abort(lambda: node.sdo.upload(0x5FFE, 0)) == 0x06020000  # no such object
    assert _abort(lambda: node.sdo.upload(0x1018, 0x09)) == 0x06090011  # no such sub-index
    assert _abort(lambda: node.sdo.download(0x6041, 0, b"\x00\x00")) == 0x06010002  # read-only
    assert _abort(lambda: node.sdo.download(0x6040, 0, b"\x00\x00\x00\x00")) == 0x06070010  # length
    if twin.od[0x6060].access_type == "wo":
        assert _abort(lambda: node.sdo.upload(0x6060, 0)) == 0x06010001  # write-only
    else:
        assert node.sdo[0x6060].raw == 0


def test_modes_follow_0x6060_after_the_switch_time(twin: Twin) -> None:
    node = twin.node
    modes = twin.modes() or [int(m) for m in twin.profile.modes]
    assert modes
    for mode in modes:
        node.sdo[0x6060].raw = mode
        if twin.profile.timing.mode_switch > 0:
            assert node.sdo[0x6061].raw != mode  # not yet
        twin.run(twin.profile.timing.mode_switch + twin.period)
        assert node.sdo[0x6061].raw == mode
    for unsupported in (m for m in (4, 7) if m not in modes):  # profile torque; ip where a twin has none
        assert _abort(lambda m=unsupported: node.sdo.download(0x6060, 0, bytes([m]))) == 0x06090030


def test_pdo_mapping_follows_the_protocol_or_is_fixed(twin: Twin) -> None:
    node = twin.node
    valid = node.sdo[0x1A00][1].raw & 0x80000000 == 0
    fixed = twin.od[0x1A00][1].access_type in ("ro", "const")
    if fixed:
        assert twin.profile.mapping == "fixed"
        node.sdo[0x1800][1].raw = node.sdo[0x1800][1].raw | 0x80000000
        assert _abort(lambda: node.sdo.download(0x1A00, 0, b"\x00")) == 0x06010002
        return
    if valid:  # the mapping of a valid PDO cannot change
        assert _abort(lambda: node.sdo.download(0x1A00, 0, b"\x00")) == 0x08000022
    node.sdo[0x1800][1].raw = node.sdo[0x1800][1].raw | 0x80000000
    node.sdo[0x1A00][0].raw = 0
    assert _abort(lambda: node.sdo[0x1A00][1].__setattr__("raw", 0x60400020)) == 0x06040041  # 32 bits
    node.sdo[0x1A00][1].raw = 0x60640020  # position actual value, 32 bits
    node.sdo[0x1A00][0].raw = 1
    node.sdo[0x1800][2].raw = 1  # every SYNC
    node.sdo[0x1800][1].raw = 0x180 + NODE  # valid
    node.nmt.state = "OPERATIONAL"
    twin.frames.clear()
    twin.run(3 * twin.period)
    tpdo1 = [d for cob, d in twin.frames if cob == 0x180 + NODE]
    assert len(tpdo1) == 3 and all(len(d) == 4 for d in tpdo1)


def test_csv_runs_in_the_drive_s_own_units(twin: Twin) -> None:
    if 9 not in (twin.modes() or [int(m) for m in twin.profile.modes]):
        pytest.skip("no CSV")
    twin.enable_csv(50.0)
    twin.run(0.5)
    assert twin.drive.axis.velocity == pytest.approx(50.0, rel=2e-3)
    assert twin.node.sdo[0x606C].raw == pytest.approx(50.0 * twin.per_rad_s(), rel=2e-3)


def test_quick_stop_brakes_along_0x6085(twin: Twin) -> None:
    twin.enable_csv(50.0)
    twin.run(0.5)
    node = twin.node
    decel = 1000.0  # rad/s^2
    node.sdo[0x6085].raw = round(decel * twin.per_rad_s())
    node.sdo[0x605A].raw = 2
    node.sdo[0x6040].raw = 0x02  # quick stop
    assert twin.state() is S.QUICK_STOP_ACTIVE
    twin.run(0.02)
    assert twin.drive.axis.velocity == pytest.approx(50.0 - decel * 0.02, abs=3.0)
    twin.run(0.2)
    assert abs(twin.drive.axis.velocity) < 0.05
    assert twin.state() is S.SWITCH_ON_DISABLED


def test_a_lost_host_heartbeat_stops_the_drive(twin: Twin) -> None:
    node = twin.node
    node.sdo[0x1016][1].raw = 0x7F << 16 | 20  # the host, node 127, every 20 ms at most
    node.sdo[0x6007].raw = 3  # quick stop
    twin.enable_csv(50.0)
    for _ in range(10):
        twin.host.send_message(0x700 + 0x7F, b"\x05")
        twin.run(0.01)
    assert twin.state() is S.OPERATION_ENABLED
    twin.run(0.3)  # the host is silent
    assert any(cob == 0x80 + NODE and d[:2] == b"\x30\x81" for cob, d in twin.frames)  # EMCY 0x8130
    assert abs(twin.drive.axis.velocity) < 0.05
    assert twin.state() is S.SWITCH_ON_DISABLED


def test_harmful_manufacturer_writes_are_seen() -> None:
    """epos4's 0x2001 is its CAN bit rate: a host that writes there is caught."""
    twin = Twin("epos4")
    try:
        assert not twin.drive.harmful_writes
        twin.node.sdo[0x2001].raw = 0
        assert twin.drive.harmful_writes == [(0x2001, 0, b"\x00\x00")]
    finally:
        twin.close()


def test_the_cp1252_eds_is_not_utf8() -> None:
    """One twin's EDS is as its vendor's: Windows-1252, which canopen's own file loader (UTF-8 by
    the locale here) refuses; a host must decode it itself."""
    path = zoo()["kollmorgen-s300"].with_suffix(".eds")
    with pytest.raises(UnicodeDecodeError):
        path.read_bytes().decode("utf-8")
    assert "\u2030" in path.read_bytes().decode("cp1252")


def test_committed_zoo_eds_files_are_what_the_generator_writes() -> None:
    from plant_emulator.devices import build

    for name in build.ZOO:
        encoding = "cp1252" if name in build.CP1252 else "ascii"
        assert (build.HERE / f"{name}.eds").read_bytes() == build.eds_of(name).encode(encoding), name
        assert name in zoo(), f"{name}.eds has no profile {name}.toml"
