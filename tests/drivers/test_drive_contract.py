"""The CiA 402 driver's contract, against every drive of the emulator's zoo always, and against a
real drive (or ``rig emulate --device NAME`` in another process) with the options rig drive takes::

    python -m pytest -m hardware tests/drivers/test_drive_contract.py --interface socketcan \\
        --channel can0 --bitrate 500000 --node 1 --eds mydrive.eds \\
        [--units counts_per_rev=51200] [--port 29536 for socketcand]

On hardware the tests move nothing: they enable the drive with a zero command and disable it; they
run one after the other on one xdist worker whatever ``-n`` is (tests/conftest.py), and a relative
``--eds`` is taken from where pytest is run (docs/tutorial-commissioning.md runs it so).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import canopen
import pytest

from drivers.base import AxisState
from drivers.bus import open_bus
from drivers.cia402 import Cia402Axis
from drivers.errors import CommunicationError, ConfigError, SdoAbort
from drivers.maps import CIA402_EDS
from plant_emulator.device_profile import load_profile, zoo
from plant_emulator.lockstep import LockstepBench

#: what a zoo drive lacks and the axis configuration must give
ZOO_UNITS = {"tmcm-1160": {"counts_per_rev": 51200.0}}
Target = tuple[Callable[..., Cia402Axis], Callable[[], None]]


def _zoo_target(
    name: str,
) -> Iterator[tuple[canopen.Network, Callable[[], None], int, str, dict[str, float]]]:
    profile = load_profile(zoo()[name])
    bench = LockstepBench(profile.physics, device=profile)
    yield bench.host, bench.sync, profile.node_id, str(profile.eds), ZOO_UNITS.get(name, {})
    bench.close()


def _hardware_target(
    config: pytest.Config,
) -> Iterator[tuple[canopen.Network, Callable[[], None], int, str, dict[str, float]]]:
    opt = config.getoption
    extra = {"host": opt("host"), "port": opt("port")} if opt("interface") == "socketcand" else {}
    bus = open_bus(opt("interface"), opt("channel"), bitrate=opt("bitrate") or None, **extra)
    network = canopen.Network(bus)
    network.connect()
    units = {}
    for item in opt("units") or []:
        name, _, value = item.partition("=")
        units[name.strip()] = float(value)
    yield network, network.sync.transmit, opt("node"), opt("eds") or CIA402_EDS, units
    network.disconnect()


@pytest.fixture(params=[*sorted(zoo()), pytest.param("hardware", marks=pytest.mark.hardware)])
def target(request: pytest.FixtureRequest) -> Iterator[Target]:
    made: list[Cia402Axis] = []
    source = _hardware_target(request.config) if request.param == "hardware" else _zoo_target(request.param)
    network, sync, node, eds, units = next(source)

    def make(mode: str = "csv") -> Cia402Axis:
        made.append(Cia402Axis("drive", network, node, mode=mode, eds=eds, units=units))
        made[-1].idle = sync
        return made[-1]

    yield make, sync
    for axis in made:
        axis.close()
    next(source, None)


def test_setup_reads_identity_and_units(target: Target) -> None:
    make, _ = target
    drive = make()
    drive.setup()
    units = drive.units
    assert units.position > 0 and units.velocity > 0
    od = drive.node.object_dictionary
    if 0x6076 in od:
        assert units.rated_torque > 0
    if 0x6075 in od:
        assert units.rated_current > 0
    assert drive.device_id.as_dict().get("vendor") is not None
    assert drive.read_state() is AxisState.DISABLED


def test_enable_disable_round_trip_with_zero_command(target: Target) -> None:
    make, sync = target
    drive = make("csv")
    drive.setup()
    drive.enable(timeout=1.0)
    assert drive.read_power_state().value == "OPERATION ENABLED"
    for _ in range(5):
        drive.command(0.0)
        sync()
    fb = drive.feedback()
    assert abs(fb.velocity) < 1.0 and math.isfinite(fb.position)
    drive.supervise(0.0)  # the statusword of the TPDO says OPERATION ENABLED
    drive.disable()
    assert drive.read_power_state().value == "SWITCH ON DISABLED"
    drive.close()
    drive.close()  # idempotent


def test_bad_access_is_an_sdo_abort_with_its_code(target: Target) -> None:
    make, _ = target
    drive = make()
    with pytest.raises(SdoAbort) as exc:
        drive.sdo_write(0x6041, 0, 0)  # statusword is read-only
    assert exc.value.code == 0x06010002 and exc.value.index == 0x6041
    with pytest.raises(SdoAbort):
        drive.sdo_read(0x5FFE)  # no such object (manufacturer range, unused)


def test_a_bus_that_cannot_open_is_a_communication_error_an_unknown_interface_a_config_error() -> None:
    """A known interface on a channel that is not there is the bus failing (naming both); an
    interface python-can does not know is the user's mistake (exit 2 in rig)."""
    with pytest.raises(CommunicationError, match="interface='socketcan' channel='no-such-can9'"):
        open_bus("socketcan", "no-such-can9")
    with pytest.raises(ConfigError, match="'no-such-interface': not a python-can interface"):
        open_bus("no-such-interface", "x")
