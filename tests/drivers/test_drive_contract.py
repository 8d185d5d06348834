"""The CiA 402 driver against the emulator always, and against a real drive with
``pytest -m hardware --can-interface socketcan --can-channel can0 --drive-node 1``.

On hardware the tests move nothing: they enable the drive with a zero command and disable it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import canopen
import pytest

from drivers.base import AxisState
from drivers.bus import open_bus
from drivers.cia402 import Cia402Axis
from drivers.errors import CommunicationError, SdoAbort
from plant_emulator.lockstep import LockstepBench


@pytest.fixture(params=["emulator", pytest.param("hardware", marks=pytest.mark.hardware)])
def target(request: pytest.FixtureRequest) -> Iterator[tuple[Callable[..., Cia402Axis], Callable[[], None]]]:
    made: list[Cia402Axis] = []
    if request.param == "emulator":
        bench = LockstepBench("dc-servo")
        network, sync, node = bench.host, bench.sync, 1
    else:
        opt = request.config.getoption
        network = canopen.Network(open_bus(opt("--can-interface"), opt("--can-channel")))
        network.connect()
        sync, node = network.sync.transmit, opt("--drive-node")

    def make(mode: str = "csv") -> Cia402Axis:
        made.append(Cia402Axis("drive", network, node, mode=mode))
        return made[-1]

    yield make, sync
    for axis in made:
        axis.close()
    if request.param == "emulator":
        bench.close()
    else:
        network.disconnect()


def test_setup_reads_identity_and_units(target) -> None:  # type: ignore[no-untyped-def]
    make, _ = target
    drive = make()
    drive.setup()
    units = drive.units
    assert units.counts_per_rad > 0 and units.rated_torque > 0 and units.rated_current > 0
    assert drive.read_state() is AxisState.DISABLED


def test_enable_disable_round_trip_with_zero_command(target) -> None:  # type: ignore[no-untyped-def]
    make, sync = target
    drive = make("csv")
    drive.setup()
    drive.enable(timeout=1.0)
    assert drive.read_power_state().value == "OPERATION ENABLED"
    for _ in range(5):
        drive.command(0.0)
        sync()
    fb = drive.feedback()
    assert abs(fb.velocity) < 1.0
    drive.supervise(0.0)  # the statusword of the TPDO says OPERATION ENABLED
    drive.disable()
    assert drive.read_power_state().value == "SWITCH ON DISABLED"
    drive.close()
    drive.close()  # idempotent


def test_bad_access_is_an_sdo_abort_with_its_code(target) -> None:  # type: ignore[no-untyped-def]
    make, _ = target
    drive = make()
    with pytest.raises(SdoAbort) as exc:
        drive.sdo_write(0x6041, 0, 0)  # statusword is read-only
    assert exc.value.code == 0x06010002 and exc.value.index == 0x6041
    with pytest.raises(SdoAbort):
        drive.sdo_read(0x5FFF)  # no such object (manufacturer range, unused)


def test_unknown_bus_is_a_communication_error() -> None:
    with pytest.raises(CommunicationError, match="no-such-interface"):
        open_bus("no-such-interface", "x")
