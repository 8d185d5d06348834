"""The CiA 402 driver against other vendors' dictionaries, served by an independent fake device.

The device (``tests/drivers/fake_device.py``) is written without drive-rig's code: it answers
as its dictionary declares (access types, aborts) and logs every SDO download and upload and
every RPDO it receives, so each test says exactly what the host wrote. The dictionaries
(``tests/drivers/dictionaries``) are written from the vendors' public facts.
"""

from __future__ import annotations

import logging
import pathlib
from collections.abc import Iterator

import pytest

from drivers.errors import ConfigError
from tests.drivers.foreign import DICTIONARIES, ForeignDrive, until

MFR_MODES = ["technosoft-ipos", "ingenia-eve", "compact-mfr-modes"]  #: not the toolkit's, 0x6502 bits 16/17


@pytest.fixture
def drive(request: pytest.FixtureRequest, tmp_path: pathlib.Path) -> Iterator[ForeignDrive]:
    d = ForeignDrive(request.param, tmp_path)
    yield d
    d.close()


def _by_index(log: list[tuple]) -> set[tuple[int, int]]:  # type: ignore[type-arg]
    return {(entry[0], entry[1]) for entry in log}


def test_ten_dictionaries_cover_the_cases() -> None:
    from tests.drivers.fake_device import Dictionary

    assert len(DICTIONARIES) >= 10
    ds = {name: Dictionary.load(name) for name in DICTIONARIES}
    no_factors = [
        n for n, d in ds.items() if not {0x608F, 0x6091, 0x6092, 0x60A8, 0x60A9} & {k[0] for k in d.entries}
    ]
    assert no_factors and any((0x6502, 0) not in d.entries for d in ds.values())
    assert ds["maxon-epos4"].entries[(0x60C2, 2)].access == "ro"
    assert ds["pilz-wo6060"].entries[(0x6060, 0)].access == "wo"
    assert ds["wittenstein-simco"].entries[(0x1600, 3)].value >> 16 == 0x3805
    assert all(ds[n].entries[(0x6502, 0)].value & 0x30000 == 0x30000 for n in MFR_MODES)


@pytest.mark.parametrize("drive", MFR_MODES, indirect=True)
@pytest.mark.parametrize("mode", ["voltage", "dq-voltage"])
def test_a_manufacturer_mode_is_refused_before_anything_is_written(drive: ForeignDrive, mode: str) -> None:
    """0x6502 bits 16/17 on a drive that is not the toolkit's are that vendor's modes (-1 is
    electronic gearing on a Technosoft): refused naming the identity and the modes offered,
    before any SDO download or NMT command."""
    axis = drive.axis(mode)
    with pytest.raises(ConfigError) as err:
        axis.setup()
    text = str(err.value)
    assert f"mode {mode!r} is a manufacturer mode of drive-rig's own drive" in text
    vendor = drive.dictionary.device["vendor"]
    assert f"vendor 0x{vendor:08X}" in text and "product 0x" in text
    assert "cyclic synchronous position (csp)" in text
    assert drive.fake.downloads == [] and drive.fake.nmt_log == []


@pytest.mark.parametrize("drive", ["technosoft-ipos"], indirect=True)
def test_manufacturer_bits_of_0x6502_mean_nothing_on_another_drive(drive: ForeignDrive) -> None:
    axis = drive.axis("csp", units={"counts_per_rev": 4096})
    axis.discover()
    assert axis.supported_modes == frozenset({1, 3, 6, 7, 8, 9, 10})
    assert not axis.toolkit_drive


@pytest.mark.parametrize("drive", ["drive-rig-own"], indirect=True)
def test_the_toolkit_s_own_drive_keeps_its_voltage_mode(drive: ForeignDrive) -> None:
    """Positively identified (0x1018 vendor 0xDB1, product 0x402): mode -1, its target 0x2100 in
    the RPDO and its command latency 0x2001."""
    axis = drive.axis("voltage")
    axis.setup()
    assert {-1, -2} <= (axis.supported_modes or set())
    axis.enable()
    axis.command(1.5)
    until(lambda: (0x2100, 0, 1500) in drive.fake.rpdo_writes, "the RPDO with 0x2100 = 1500 mV")
    assert (0x2001, 0, 0, None) in drive.fake.downloads


@pytest.mark.parametrize("drive", ["wittenstein-simco"], indirect=True)
@pytest.mark.parametrize("mode", ["csp", "csv"])
def test_a_fixed_rpdo_holding_a_manufacturer_object_is_refused(drive: ForeignDrive, mode: str) -> None:
    """The drive's own RPDO carries 0x3805 beside the target: the host would send back what it
    read, a write to a manufacturer object every cycle. Refused, naming it; the fixed mapping is
    not even tried (its EDS declares it const)."""
    axis = drive.axis(mode, units={"counts_per_rev": 4096})
    with pytest.raises(ConfigError, match=r"RPDO\d, which carries the mode's target, also carries 0x3805:00"):
        axis.setup()
    assert drive.fake.manufacturer_writes() == [] and drive.fake.rpdos == []
    assert not [w for w in drive.fake.downloads if 0x1400 <= w[0] < 0x1800]


@pytest.mark.parametrize("drive", ["ingenia-eve", "technosoft-ipos", "maxon-epos4"], indirect=True)
def test_a_cyclic_run_writes_no_manufacturer_object(drive: ForeignDrive) -> None:
    axis = drive.axis("csv", units={"counts_per_rev": 4096}, period=0.001)
    axis.setup()
    axis.enable()
    for _ in range(5):
        axis.command(3.0)
    until(lambda: len(drive.fake.rpdos) >= 5, "five RPDOs")
    assert drive.fake.manufacturer_writes() == []
    index = min(k[0] for k in drive.dictionary.entries if 0x2000 <= k[0] < 0x6000)
    with pytest.raises(ConfigError, match=rf"would write 0x{index:04X} .*a manufacturer object of vendor"):
        axis.sdo_write(index, 0, 1)
    assert drive.fake.manufacturer_writes() == []


@pytest.mark.parametrize("drive", ["maxon-epos4"], indirect=True)
def test_a_read_only_interpolation_index_is_read_and_honoured(drive: ForeignDrive) -> None:
    """0x60C2:02 is read-only at -3 (milliseconds): 10 ms is 10 x 10^-3, sub 2 is never written."""
    axis = drive.axis("csp", period=0.01)
    axis.setup()
    assert (0x60C2, 2) not in _by_index(drive.fake.downloads)
    assert drive.fake.value(0x60C2, 1) == 10 and drive.fake.value(0x60C2, 2) == -3


@pytest.mark.parametrize("drive", ["maxon-epos4"], indirect=True)
def test_a_period_the_drive_s_exponent_cannot_hold_is_one_warning(
    drive: ForeignDrive, caplog: pytest.LogCaptureFixture
) -> None:
    axis = drive.axis("csp", period=0.0004)
    with caplog.at_level(logging.WARNING):
        axis.setup()
    assert (0x60C2, 2) not in _by_index(drive.fake.downloads)
    said = [r.getMessage() for r in caplog.records if "0x60C2" in r.getMessage()]
    assert len(said) == 1 and "the drive interpolates over 1 ms" in said[0] and "400 us" in said[0]


@pytest.mark.parametrize("drive", ["faulhaber-mc5004"], indirect=True)
def test_the_drive_s_own_exponent_is_kept_where_it_can_hold_the_period(drive: ForeignDrive) -> None:
    axis = drive.axis("csp", period=0.01)
    axis.setup()
    assert (0x60C2, 2) not in _by_index(drive.fake.downloads)
    assert drive.fake.value(0x60C2, 1) == 10


@pytest.mark.parametrize("drive", ["zeroerr-erob"], indirect=True)
def test_a_read_only_cycle_period_is_read_not_written(
    drive: ForeignDrive, caplog: pytest.LogCaptureFixture
) -> None:
    axis = drive.axis("csp", period=0.002, units={"counts_per_rev": 4096})
    with caplog.at_level(logging.WARNING):
        axis.setup()
    assert (0x1006, 0) not in _by_index(drive.fake.downloads) and (0x1006, 0) in _by_index(drive.fake.uploads)
    assert "0x1006:00 (Communication cycle period) is ro in the EDS and holds 1000" in caplog.text


@pytest.mark.parametrize("drive", ["faulhaber-mc5004"], indirect=True)
def test_an_optional_refusal_is_one_warning_and_a_required_one_an_error(
    drive: ForeignDrive, caplog: pytest.LogCaptureFixture
) -> None:
    """The device refuses what its EDS declares writable: 0x1006 (optional) is one warning; 0x6060
    (required) is one line naming the object, the abort code in words and the EDS's access type."""
    drive.fake.set_access(0x1006, 0, "ro")
    with caplog.at_level(logging.WARNING):
        drive.axis("csp", period=0.001).setup()
    said = [r.getMessage() for r in caplog.records if "0x1006" in r.getMessage()]
    assert len(said) == 1
    assert "0x1006:00 (Communication cycle period) refused 1000" in said[0]
    assert "attempt to write a read-only object; the EDS declares it rw" in said[0]
    drive.fake.set_access(0x6060, 0, "ro")
    with pytest.raises(ConfigError) as err:
        drive.axis("csv").setup()
    assert "\n" not in str(err.value)
    assert "0x6060:00 (Modes of operation) refused 9" in str(err.value)
    assert "abort 0x06010002, attempt to write a read-only object; the EDS declares it rw" in str(err.value)


@pytest.mark.parametrize("drive", ["pilz-wo6060"], indirect=True)
def test_a_write_only_6060_is_written_never_read(drive: ForeignDrive) -> None:
    axis = drive.axis("csp", period=0.001)
    axis.setup()
    axis.enable()
    assert (0x6060, 0) in _by_index(drive.fake.downloads)
    assert (0x6060, 0) not in _by_index(drive.fake.uploads)


@pytest.mark.parametrize("drive", ["schunk-no6502"], indirect=True)
def test_a_drive_without_0x6502_runs_its_cia_modes_and_refuses_the_toolkit_s(drive: ForeignDrive) -> None:
    axis = drive.axis("csp", period=0.001)
    axis.setup()
    assert axis.supported_modes is None
    with pytest.raises(
        ConfigError, match=r"it offers no 0x6502 \(the drive does not say which modes it has\)"
    ):
        drive.axis("voltage").setup()
