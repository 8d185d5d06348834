"""The CiA 402 driver contract: runs against the emulator always, and against a real drive with
``pytest -m hardware --can-interface socketcan --can-channel can0 --drive-node 1``.

On hardware the tests move nothing: they enable the drive with a zero command and disable it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import canopen
import pytest

from drivers.bus import open_bus
from drivers.cia402 import Cia402Drive
from drivers.errors import CommunicationError, SdoAbort
from plant_emulator.lockstep import LockstepBench


@pytest.fixture(params=["emulator", pytest.param("hardware", marks=pytest.mark.hardware)])
def target(request: pytest.FixtureRequest) -> Iterator[tuple[Cia402Drive, Callable[[], None]]]:
    if request.param == "emulator":
        bench = LockstepBench("dc-servo")
        yield Cia402Drive(bench.host, 1), bench.sync
        bench.close()
        return
    opt = request.config.getoption
    network = canopen.Network(open_bus(opt("--can-interface"), opt("--can-channel")))
    network.connect()
    yield Cia402Drive(network, opt("--drive-node")), network.sync.transmit
    network.disconnect()


def test_connect_reads_identity_and_units(target) -> None:  # type: ignore[no-untyped-def]
    drive, _ = target
    units = drive.connect()
    assert units.counts_per_rad > 0 and units.rated_torque > 0 and units.rated_current > 0


def test_enable_disable_round_trip_with_zero_command(target) -> None:  # type: ignore[no-untyped-def]
    drive, sync = target
    drive.connect()
    drive.nmt("PRE-OPERATIONAL")
    drive.set_mode("csv")
    drive.configure_pdos(sync_rpdo=True)
    drive.nmt("OPERATIONAL")
    drive.enable(timeout=1.0)
    assert drive.state == "OPERATION ENABLED"
    for _ in range(5):
        drive.command(0.0)
        sync()
    _, velocity, _, _, statusword = drive.feedback()
    assert statusword & 0x6F == 0x27 and abs(velocity) < 1.0
    drive.disable()
    assert drive.state == "SWITCH ON DISABLED"


def test_bad_access_is_an_sdo_abort_with_its_code(target) -> None:  # type: ignore[no-untyped-def]
    drive, _ = target
    with pytest.raises(SdoAbort) as exc:
        drive.sdo_write(0x6041, 0, 0)  # statusword is read-only
    assert exc.value.code == 0x06010002 and exc.value.index == 0x6041
    with pytest.raises(SdoAbort):
        drive.sdo_read(0x5FFF)  # no such object (manufacturer range, unused)


def test_unknown_bus_is_a_communication_error() -> None:
    with pytest.raises(CommunicationError, match="no-such-interface"):
        open_bus("no-such-interface", "x")
