"""Identity before motion, units and modes from the device: the CiA 402 driver against the other
vendors' dictionaries (``tests/drivers/dictionaries``) served by the independent fake device, with
the device's own EDS, with another device's, and with none (the toolkit's generic one)."""

from __future__ import annotations

import logging
import math
import pathlib
from collections.abc import Iterator

import pytest

from drivers.errors import ConfigError
from drivers.identity import declared_identity
from drivers.maps import CIA402_EDS
from drivers.maps.od import load_od
from tests.drivers.fake_device import Dictionary
from tests.drivers.foreign import DICTIONARIES, ForeignDrive

TWO_PI = 2.0 * math.pi


@pytest.fixture
def drive(request: pytest.FixtureRequest, tmp_path: pathlib.Path) -> Iterator[ForeignDrive]:
    d = ForeignDrive(request.param, tmp_path)
    yield d
    d.close()


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == pytest.approx(b, rel=1e-12)


@pytest.mark.parametrize("drive", DICTIONARIES, indirect=True)
def test_units_and_modes_come_from_the_device_whatever_the_eds(drive: ForeignDrive) -> None:
    """Without the device's own EDS (the toolkit's generic one in use) the driver finds the same
    identity, modes, units and position as with it: each is read from the device, never taken from
    an EDS's default values; and reading them writes nothing."""
    own = drive.axis("csp")
    own.discover(check_mode=False)
    generic = drive.axis("csp", eds=None)
    generic.discover(check_mode=False)
    assert generic.device_id.as_dict() == own.device_id.as_dict()
    assert generic.discovery.supported_modes == own.discovery.supported_modes
    assert (
        generic.discovery.has_position
        == own.discovery.has_position
        == ((0x6064, 0) in drive.dictionary.entries)
    )
    for field in ("position", "velocity", "rated_torque", "rated_current"):
        assert _same(getattr(generic.units, field), getattr(own.units, field)), field
    assert drive.fake.downloads == [] and drive.fake.nmt_log == []


#: (dictionary, position units per rad, velocity units per rad/s, where each came from)
CONVENTIONS = [
    ("nanotec-c5e", 3600.0 / TWO_PI, 60.0 / TWO_PI, "0x60A8", "0x60A9"),  # 0.1 degree and rpm
    ("maxon-epos4", 4096.0 / TWO_PI, 60.0 / TWO_PI, "0x608F", "0x60A9"),  # increments and rpm
    ("trinamic-tmcm1270", 51200.0 / TWO_PI, 51200.0 / TWO_PI, "0x6092", "0x6092"),  # microsteps (feed)
    ("sevcon-gen4", math.nan, 60.0 / TWO_PI, None, "0x608B/0x608C"),  # rpm by the older notation
    ("sevcon-nano", math.nan, 60.0 / TWO_PI, None, "0x608B/0x608C"),  # by 0x608C alone
]


@pytest.mark.parametrize(
    ("drive", "position", "velocity", "pos_from", "vel_from"), CONVENTIONS, indirect=["drive"]
)
def test_each_unit_convention_without_an_eds(
    drive: ForeignDrive, position: float, velocity: float, pos_from: str | None, vel_from: str
) -> None:
    axis = drive.axis("csp", eds=None)
    units = axis.discover(check_mode=False)
    assert _same(units.position, position) and _same(units.velocity, velocity)
    assert units.source.get("position") == pos_from and units.source["velocity"] == vel_from


@pytest.mark.parametrize("drive", ["nanotec-c5e"], indirect=True)
def test_si_units_in_milliradian(drive: ForeignDrive) -> None:
    """0x60A8/0x60A9 in mrad and mrad/s (prefix -3, unit 0x10, per second 0x03) as the device
    holds them at the time of the set-up."""
    drive.fake.od.entries[(0x60A8, 0)].value = 0xFD100000
    drive.fake.od.entries[(0x60A9, 0)].value = 0xFD100300
    units = drive.axis("csp", eds=None).discover(check_mode=False)
    assert units.position == pytest.approx(1000.0) and units.velocity == pytest.approx(1000.0)


@pytest.mark.parametrize("drive", ["nanotec-c5e"], indirect=True)
@pytest.mark.parametrize("other", ["maxon-epos4", "toolkit"])
def test_an_eds_of_another_device_is_refused_before_anything_is_written(
    drive: ForeignDrive, other: str, tmp_path: pathlib.Path
) -> None:
    eds = CIA402_EDS if other == "toolkit" else str(Dictionary.load(other).write_eds(tmp_path))
    axis = drive.axis("csv", eds=eds)
    with pytest.raises(ConfigError) as err:
        axis.setup()
    text = str(err.value)
    assert "\n" not in text
    assert "is vendor 0x0000026C (Nanotec Electronic GmbH & Co. KG) / product 0x00000010" in text
    declared = declared_identity(load_od(eds, 1))
    assert f"describes vendor 0x{declared.vendor:08X}" in text and eds in text
    assert "give the device's own EDS/DCF" in text
    assert drive.fake.downloads == [] and drive.fake.nmt_log == []
    axis.close()
    assert drive.fake.downloads == []  # closing a refused drive writes no controlword either


@pytest.mark.parametrize("drive", ["maxon-epos4"], indirect=True)
def test_another_revision_is_a_warning(drive: ForeignDrive, caplog: pytest.LogCaptureFixture) -> None:
    drive.fake.od.entries[(0x1018, 3)].value = 0x01800000
    axis = drive.axis("csv")
    with caplog.at_level(logging.WARNING):
        axis.discover()
    assert axis.device_id.as_dict()["revision"] == 0x01800000
    assert any(
        "revision 0x01800000" in r.getMessage() and "0x01700000" in r.getMessage() for r in caplog.records
    )


@pytest.mark.parametrize("drive", ["nanotec-c5e"], indirect=True)
def test_no_eds_names_the_vendor_from_the_vendor_list_not_the_toolkit(drive: ForeignDrive) -> None:
    axis = drive.axis("csp", eds=None)
    axis.discover(check_mode=False)
    assert axis.device_id.vendor == 0x26C
    assert axis.device_id.vendor_name == "Nanotec Electronic GmbH & Co. KG"  # CiA's list, not the EDS
    assert "drive-rig" not in axis.device_id.text()
    own = drive.axis("csp")
    own.discover(check_mode=False)
    assert own.device_id.vendor_name == "Nanotec"
