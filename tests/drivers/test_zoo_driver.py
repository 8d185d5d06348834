"""drive-rig's CiA 402 driver against every drive of the emulator's zoo: it adapts to each one.

Each zoo drive is the twin of a commercial drive's object dictionary (units, PDO counts,
fixed mappings, write-only objects, manufacturer objects with other meanings); the driver
must set each up from what the drive offers, run it in CSV and CSP, write nothing into its
manufacturer objects, and name what is missing when the drive cannot do what is asked.
"""

from __future__ import annotations

import logging
import math
import pathlib
from collections.abc import Iterator

import canopen
import pytest

from drivers.cia402 import Cia402Axis
from drivers.errors import ConfigError, DeviceFault
from drivers.maps.emcy import emcy_text
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.device_profile import DeviceProfile, load_profile, zoo
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.presets import build_twin

PROFILES = sorted(zoo())
#: what a profile's drive lacks and the axis configuration must give
GIVEN = {"tmcm-1160": {"counts_per_rev": 51200.0}}


class Rig:
    """A zoo drive (node 1) on an in-process bus, lock-step, and the driver's network."""

    def __init__(self, name: str) -> None:
        self.profile: DeviceProfile = load_profile(zoo()[name])
        self.hub = SyncHub()
        self.host, self.dev = canopen.Network(), canopen.Network()
        attach_network(self.host, self.hub.bus(queue=False, channel="host"))
        attach_network(self.dev, self.hub.bus(queue=False, channel="device"))
        devices, self.period = build_twin(self.profile, self.dev)
        drive = devices[0]
        assert isinstance(drive, EmulatedDrive)
        self.drive = drive
        drive.boot()
        self.syncs = 0

    def sync(self) -> None:
        self.syncs += 1
        self.hub.clock = self.syncs * self.period
        self.host.send_message(0x80, b"")

    def axis(self, mode: str, **kw: object) -> Cia402Axis:
        units = kw.pop("units", GIVEN.get(self.profile.name, {}))
        axis = Cia402Axis("motor", self.host, 1, mode=mode, eds=str(self.profile.eds), units=units, **kw)  # type: ignore[arg-type]
        axis.idle = self.sync
        return axis

    def close(self) -> None:
        for net in (self.host, self.dev):
            net.bus.shutdown()


@pytest.fixture(params=PROFILES)
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    r = Rig(request.param)
    yield r
    r.close()


@pytest.mark.parametrize(("mode", "command"), [("csv", 20.0), ("csp", 2.0)])
def test_every_zoo_drive_runs(rig: Rig, mode: str, command: float) -> None:
    with rig.axis(mode) as axis:
        axis.setup()
        axis.enable()
        for _ in range(1000):
            axis.command(command)
            rig.sync()
            fb = axis.feedback()
            axis.supervise(rig.hub.clock)
        quantum = 2.0 / axis.units.position  # [rad] two position units
        if mode == "csv":
            assert fb.velocity == pytest.approx(20.0, rel=2e-3)  # within the units' quantisation (rpm)
        else:
            assert fb.position == pytest.approx(2.0, abs=quantum)
        assert rig.drive.axis.position == pytest.approx(fb.position, abs=quantum)
        assert rig.drive.harmful_writes == []


def test_a_fixed_mapping_falls_back_to_the_drive_s_own(caplog: pytest.LogCaptureFixture) -> None:
    r = Rig("erl-pcs")
    try:
        with r.axis("csv") as axis:
            with caplog.at_level(logging.WARNING):
                axis.setup()
            assert axis.mapping.pdo == "device"
        assert "mapping is fixed (0x1600:00 is" in caplog.text and "using its own" in caplog.text
    finally:
        r.close()


def test_a_tpdo_not_yet_received_is_not_read_as_zeros() -> None:
    """With the drive's own mapping, 0x6061 travels in another TPDO than the statusword; until
    that TPDO first arrives (real time: a frame later), its zeros are not a mode change."""
    from drivers.cia402_setup import MODE_SHOWN, SW
    from drivers.errors import SafetyStop

    r = Rig("erl-pcs")
    try:
        with r.axis("csv") as axis:
            axis.setup()
            axis.enable()
            assert axis.data is not None
            mode_slot = axis.data.slot_of(MODE_SHOWN)
            assert mode_slot is not None and mode_slot is not axis.data.slot_of(SW)
            for _ in range(3):  # statusword TPDOs arrive; the mode's is held back
                axis.command(0.0)
                r.host.send_message(0x80, b"")
                mode_slot.timestamp, mode_slot.data = None, bytes(mode_slot.codec.size)
                axis.supervise(r.hub.clock)
            r.sync()
            axis.supervise(r.hub.clock)  # now received: the drive's mode
            mode_slot.data = bytes(mode_slot.codec.size)  # a received 0: a real change
            with pytest.raises(SafetyStop, match="changed its mode to 0"):
                axis.supervise(r.hub.clock)
    finally:
        r.close()


def test_a_write_only_modes_of_operation_is_not_read() -> None:
    r = Rig("compact-2pdo")
    try:
        assert r.drive.od.node.object_dictionary[0x6060].access_type == "wo"
        with r.axis("csp") as axis:
            axis.setup()  # 0x6060 written, 0x6061 read back: no read of 0x6060
    finally:
        r.close()


def _refused(r: Rig, mode: str, match: str, **kw: object) -> None:
    """Set-up of ``mode`` fails with a ConfigError matching ``match``; the axis is closed."""
    with r.axis(mode, **kw) as axis, pytest.raises(ConfigError, match=match):
        axis.setup()


def test_a_factor_nobody_gives_is_named() -> None:
    r = Rig("tmcm-1160")
    try:
        _refused(
            r,
            "csv",
            r"mode CSV needs the drive.s velocity unit.*set \[axis.units\] velocity_unit .*counts_per_rev",
            units={},
        )
    finally:
        r.close()
    r = Rig("compact-2pdo")
    try:
        _refused(r, "cst", r"needs 0x6076.*set \[axis.units\] rated_torque")
        with r.axis("cst", units={"rated_torque": 0.235}) as axis:
            axis.setup()
            assert axis.units.rated_torque == 0.235
    finally:
        r.close()


def test_a_mode_the_drive_does_not_offer_is_refused_before_0x6060() -> None:
    r = Rig("tmcm-1160")
    try:
        _refused(r, "cst", r"mode cst is not in 0x6502")
        assert r.drive.read(0x6061) == 0  # nothing was written
    finally:
        r.close()


def test_units_are_the_drive_s_own() -> None:
    """Nanotec's twin: position in 0.1 degree, velocity in rpm; found by the driver."""
    r = Rig("nanotec-c5e")
    try:
        with r.axis("csv") as axis:
            units = axis.discover()
        assert units.position == pytest.approx(3600 / (2 * math.pi))
        assert units.velocity == pytest.approx(60 / (2 * math.pi))
        assert units.source["position"] == "0x60A8" and units.source["velocity"] == "0x60A9"
    finally:
        r.close()


def test_a_drive_found_in_fault_is_refused_or_reset(caplog: pytest.LogCaptureFixture) -> None:
    """A drive that starts in FAULT: enable refuses, saying what 0x603F holds, unless told to
    reset it (rising edge of controlword bit 7, confirmed by the statusword)."""
    r = Rig("epos4")
    try:
        r.drive.raise_fault(0x8611)
        for _ in range(2000):  # the fault reaction's ramp (the motor is at rest: at once)
            r.sync()
        with r.axis("csv") as axis:
            axis.setup()
            with pytest.raises(
                DeviceFault, match=r"in FAULT \(0x603F = 0x8611, following error\).*reset_fault"
            ):
                axis.enable()
        with r.axis("csv", reset_fault=True) as axis, caplog.at_level(logging.WARNING):
            axis.setup()
            axis.enable()
            assert axis.read_power_state().value == "OPERATION ENABLED"
        assert "was in FAULT (0x603F = 0x8611, following error): resetting" in caplog.text
    finally:
        r.close()


def test_emcy_codes_in_words_from_the_device_profile(tmp_path: pathlib.Path) -> None:
    """The device's own EMCY texts (the [emcy] of the profile next to its EDS), else CiA's."""
    from rig.host.axes import device_emcy_texts

    eds = tmp_path / "mydrive.eds"
    eds.write_bytes(load_profile(zoo()["epos4"]).eds.read_bytes())
    (tmp_path / "mydrive.toml").write_text('[emcy]\n0x7380 = "resolver wire break"\n')
    texts = device_emcy_texts(str(eds))
    assert texts == {0x7380: "resolver wire break"}
    assert emcy_text(0x7380, texts) == "resolver wire break"
    assert emcy_text(0x7381, texts) == "sensor"  # the class, from CiA 301
    assert emcy_text(0x8611) == "following error"
    r = Rig("epos4")
    try:
        with r.axis("csv", emcy_texts=texts) as axis:
            axis.setup()
            axis.enable()
            r.drive.emcy(0x7380, 0x81)
            assert axis.fault is not None and "EMCY 0x7380 (resolver wire break)" in str(axis.fault)
    finally:
        r.close()


@pytest.mark.parametrize("csp_enable", ["target", "hold"])
def test_csp_enables_where_the_drive_stands(csp_enable: str) -> None:
    """0x607A is absolute: a drive enabled in CSP goes for whatever it holds (CiA 402; the twin's
    ``csp_enable = "target"``). The driver sets it to the position the drive reads first, so
    a target left from before (here 10 rev away) moves nothing."""
    import dataclasses

    r = Rig("epos4")
    r.drive.profile = dataclasses.replace(r.drive.profile, csp_enable=csp_enable)
    try:
        r.drive.shaft.motion.x[0] = 3.0  # type: ignore[attr-defined]
        stale = round(r.drive.counts_per_rad * 2 * math.pi * 10)
        r.drive.od.write(0x607A, 0, stale)
        with r.axis("csp") as axis:
            axis.setup()
            axis.enable()
            for _ in range(200):  # no command from the host yet: the drive keeps its target
                r.sync()
                axis.supervise(r.hub.clock)
            assert r.drive.fault_code == 0
            assert r.drive.shaft.position == pytest.approx(3.0, abs=2e-3)
    finally:
        r.close()


def test_a_stale_csp_target_moves_the_twin() -> None:
    """The twin is true to that danger: enabled in CSP with a stale 0x607A by a host that does
    not set it, it goes for it (and its following-error supervision trips)."""
    r = Rig("epos4")
    try:
        node = canopen.RemoteNode(1, str(r.profile.eds))
        r.host.add_node(node)
        node.nmt.state = "OPERATIONAL"
        node.sdo[0x6060].raw = 8
        r.sync()
        node.sdo[0x607A].raw = round(r.drive.counts_per_rad * 2.0)  # 2 rad
        for cw in (0x06, 0x07, 0x0F):
            node.sdo[0x6040].raw = cw
        for _ in range(300):
            r.sync()
        moved = r.drive.shaft.position
        assert moved > 0.5 or r.drive.fault_code == 0x8611, moved
    finally:
        r.close()
