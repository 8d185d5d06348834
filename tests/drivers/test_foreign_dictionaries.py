"""The CiA 402 driver against other vendors' dictionaries, served by an independent fake device.

The device (``tests/drivers/fake_device.py``) is written without drive-rig's code: it answers
as its dictionary declares (access types, aborts) and logs every SDO download and upload and
every RPDO it receives, so each test says exactly what the host wrote. The dictionaries
(``tests/drivers/dictionaries``) are written from the vendors' public facts.
"""

from __future__ import annotations

import logging
import math
import pathlib
from collections.abc import Iterator

import pytest

from drivers.errors import ConfigError, SdoAbort
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
    assert ds["beckhoff-ax8000"].entries[(0x6502, 0)].value == 0x780  # cstca, no profile modes
    assert 8 not in ds["kinco-fd5p"].device["modes"] and ds["kinco-fd5p"].entries[(0x6502, 0)].value & 0x80
    assert ds["elmo-gold"].pdo_preop_only
    assert not any(k[0] == 0x60C2 for k in ds["copley-accelnet"].entries)
    assert not any(k[0] == 0x1016 for k in ds["jvl-mac"].entries)
    keys = {k[0] for k in ds["trinamic-tmcm1270"].entries}
    assert {0x608F, 0x6092} <= keys and 0x6091 not in keys


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
    assert axis.discovery.supported_modes == frozenset({1, 3, 6, 7, 8, 9, 10})
    assert not axis.toolkit_drive


@pytest.mark.parametrize("drive", ["drive-rig-own"], indirect=True)
def test_the_toolkit_s_own_drive_keeps_its_voltage_mode(drive: ForeignDrive) -> None:
    """Positively identified (0x1018 vendor 0xDB1, product 0x402): mode -1, its target 0x2100 in
    the RPDO and its command latency 0x2001."""
    axis = drive.axis("voltage")
    axis.setup()
    assert {-1, -2} <= (axis.discovery.supported_modes or set())
    axis.enable()
    axis.command(1.5)
    until(lambda: (0x2100, 0, 1500) in drive.fake.rpdo_writes, "the RPDO with 0x2100 = 1500 mV")
    assert (0x2001, 0, 0, None) in drive.fake.downloads


@pytest.mark.parametrize("drive", ["wittenstein-simco"], indirect=True)
@pytest.mark.parametrize("mode", ["csp", "csv"])
def test_a_fixed_rpdo_holding_a_manufacturer_object_is_refused(drive: ForeignDrive, mode: str) -> None:
    """The drive's own RPDO carries 0x3805 beside the target: the host would send back what it
    read, a write to a manufacturer object every cycle. Refused, naming it, from what was read:
    the fixed mapping is not even tried (its EDS declares it const), and neither 0x6060 nor an NMT
    command is sent (nor, at the close, a controlword)."""
    axis = drive.axis(mode, units={"counts_per_rev": 4096})
    with pytest.raises(ConfigError, match=r"RPDO\d, which carries the mode's target, also carries 0x3805:00"):
        axis.setup()
    axis.close()
    assert drive.fake.downloads == [] and drive.fake.nmt_log == [] and drive.fake.rpdos == []


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
    assert axis.discovery.supported_modes is None
    with pytest.raises(
        ConfigError, match=r"it offers no 0x6502 \(the drive does not say which modes it has\)"
    ):
        drive.axis("voltage").setup()


def test_every_abort_code_of_cia301_is_said_in_words() -> None:
    """CiA 301's table of SDO abort codes, the block-transfer ones included, as canopen (software
    we did not write) lists them too."""
    from canopen.sdo.exceptions import SdoAbortedError

    from drivers.maps.sdo_aborts import ABORT_TEXTS, abort_text

    assert set(ABORT_TEXTS) == set(SdoAbortedError.CODES)
    assert abort_text(0x05040004) == "CRC error (block mode only)"
    assert abort_text(0x05040002) == "invalid block size (block mode only)"
    assert abort_text(0x12345678) == "an abort code CiA 301 does not list"


@pytest.mark.parametrize(
    ("drive", "named"),
    [
        ("beckhoff-ax8000", "cyclic synchronous torque with commutation angle (cstca)"),
        ("roboteq-sbl", "velocity (vl)"),
    ],
    indirect=["drive"],
)
def test_the_modes_offered_name_every_bit_cia_402_defines(drive: ForeignDrive, named: str) -> None:
    """0x6502 bit 10 (cstca, mode 11) and bit 1 (vl, mode 2) are CiA 402's, not the vendor's."""
    axis = drive.axis("csp")
    axis.discover(check_mode=False)
    bits = drive.dictionary.entries[(0x6502, 0)].value
    assert named in axis.discovery.offered(bits)
    assert drive.fake.downloads == []


@pytest.mark.parametrize("drive", ["roboteq-sbl"], indirect=True)
def test_a_velocity_unit_in_rpm_needs_no_increments(drive: ForeignDrive) -> None:
    """0x60A9 = rpm without any position factor: the velocity's factor is known (60 / 2 pi)."""
    units = drive.axis("csp").discover(check_mode=False)
    assert units.velocity == pytest.approx(60.0 / (2.0 * math.pi)) and units.source["velocity"] == "0x60A9"
    assert math.isnan(units.position)


@pytest.mark.parametrize("drive", ["kinco-fd5p"], indirect=True)
def test_a_mode_0x6502_lists_but_0x6060_refuses_says_what_to_do(drive: ForeignDrive) -> None:
    with pytest.raises(ConfigError) as err:
        drive.axis("csp", units={"counts_per_rev": 4096}).setup()
    text = str(err.value)
    assert "0x6060:00 (Modes of operation) refused 8" in text and "abort 0x06090030" in text
    assert text.endswith("set the axis's mode to another it offers (pv, csv, cst)") and "\n" not in text


@pytest.mark.parametrize("drive", ["maxon-epos2"], indirect=True)
def test_a_mode_the_drive_lacks_is_refused_with_the_ones_it_has(drive: ForeignDrive) -> None:
    with pytest.raises(
        ConfigError, match=r"mode csp is not in 0x6502 .*: set the axis's mode to another it offers \(pv\)$"
    ):
        drive.axis("csp", units={"counts_per_rev": 4096}).setup()
    assert drive.fake.downloads == [] and drive.fake.nmt_log == []


@pytest.mark.parametrize("drive", ["kinco-fd5p"], indirect=True)
def test_a_heartbeat_consumer_entry_watching_another_node_is_left_alone(
    drive: ForeignDrive, caplog: pytest.LogCaptureFixture
) -> None:
    """0x1016 has one entry, and it watches node 5: the host does not take it over."""
    axis = drive.axis("cst", units={"counts_per_rev": 4096}, host=(127, 0.3), period=0.001)
    with caplog.at_level(logging.WARNING):
        axis.setup()
        axis.enable()
    assert (0x1016, 1) not in _by_index(drive.fake.downloads)
    said = [r.getMessage() for r in caplog.records if "0x1016" in r.getMessage()]
    assert said and "0x1016:01 node 5 (500 ms)" in said[0] and "will not stop itself" in said[0]


@pytest.mark.parametrize("drive", ["jvl-mac"], indirect=True)
def test_a_drive_without_a_heartbeat_consumer_is_one_warning(
    drive: ForeignDrive, caplog: pytest.LogCaptureFixture
) -> None:
    axis = drive.axis("csp", host=(127, 0.3), period=0.001)
    with caplog.at_level(logging.WARNING):
        axis.setup()
    said = [r.getMessage() for r in caplog.records if "0x1016" in r.getMessage()]
    assert len(said) == 1 and "has no heartbeat consumer (0x1016)" in said[0]


@pytest.mark.parametrize("drive", ["elmo-gold"], indirect=True)
@pytest.mark.parametrize("mode", ["csp", "csv", "cst"])
def test_a_mapping_changed_only_in_pre_operational_with_bit_31_first(drive: ForeignDrive, mode: str) -> None:
    """The drive takes PDO parameters only in PRE-OPERATIONAL and a transmission type only while
    the COB-ID's bit 31 is set: the CiA 301 order is followed, nothing is refused."""
    axis = drive.axis(mode, period=0.001)
    axis.setup()
    assert [w for w in drive.fake.downloads if w[3] is not None] == []
    assert any(0x1600 <= w[0] < 0x1800 for w in drive.fake.downloads)
    with pytest.raises(SdoAbort) as err:  # the device does refuse it once OPERATIONAL
        axis.sdo_write(0x1400, 2, 1)
    assert err.value.code == 0x08000022


@pytest.mark.parametrize("drive", ["copley-accelnet"], indirect=True)
def test_a_drive_without_an_interpolation_period_object(drive: ForeignDrive) -> None:
    axis = drive.axis("csp", period=0.002)
    axis.setup()
    assert 0x60C2 not in {w[0] for w in drive.fake.downloads} | {u[0] for u in drive.fake.uploads}
    assert (0x1006, 0, 2000, None) in drive.fake.downloads


@pytest.mark.parametrize("drive", ["maxon-epos4"], indirect=True)
@pytest.mark.parametrize(("mode", "target"), [("csv", 0x60FF), ("cst", 0x6071)])
def test_a_velocity_or_torque_target_left_from_before_is_zeroed_before_the_enable(
    drive: ForeignDrive, mode: str, target: int
) -> None:
    """The drive acts on 0x60FF (0x6071) as it stands once enabled: a target left by an earlier
    tool is set to 0 before the enable, not after."""
    drive.fake.od.entries[(target, 0)].value = 500
    axis = drive.axis(mode, period=0.001)
    axis.setup()
    axis.enable()
    writes = [(w[0], w[2]) for w in drive.fake.downloads]
    assert writes.index((target, 0)) < writes.index((0x6040, 15))
