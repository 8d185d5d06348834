"""The one axis contract (``drivers.base.AxisDriver``), kept by every driver: CiA 402, CiA 406, Modbus.

Each runs against its emulated device: setup moves nothing, enable/disable/quick stop give the
states the contract names, feedback is SI in the fields the axis measures, errors are the
toolkit's (never a library's), and close is idempotent and leaves the device disabled.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from drivers.base import AxisDriver, AxisState
from drivers.cia402 import Cia402Axis
from drivers.cia406 import Cia406Axis
from drivers.errors import CommunicationError, RigError, SafetyStop
from drivers.maps import cia, modbus_map
from drivers.modbus_inverter import ModbusInverterAxis
from plant_emulator.lockstep import LockstepBench
from plant_emulator.modbus_inverter import InverterModel, InverterServer

Target = tuple[AxisDriver, Callable[[], None]]


@pytest.fixture(params=["cia402", "cia406", "modbus"])
def target(request: pytest.FixtureRequest) -> Iterator[Target]:
    if request.param == "modbus":
        model = InverterModel(modbus_map("abb-drives-profile"))
        with InverterServer(model, dt=None) as server:
            axis: AxisDriver = ModbusInverterAxis(
                "inverter", "abb-drives-profile", host="127.0.0.1", port=server.port
            )
            yield axis, lambda: model.step(0.01)
            axis.close()
        return
    bench = LockstepBench("dc-servo")
    if request.param == "cia402":
        axis = Cia402Axis("drive", bench.host, 1, mode="csv")
    else:
        axis = Cia406Axis("encoder", bench.host, 2, period=bench.period)
    yield axis, bench.sync
    axis.close()
    bench.close()


def test_setup_moves_nothing_and_enable_disable_round_trip(target: Target) -> None:
    axis, tick = target
    axis.setup()
    if not axis.commandable:
        assert axis.read_state() is AxisState.ENABLED  # an encoder runs once operational
        return
    assert axis.read_state() is AxisState.DISABLED
    axis.enable(timeout=1.0)
    assert axis.read_state() is AxisState.ENABLED
    for _ in range(5):
        axis.command(0.0)
        tick()
    axis.feedback()
    axis.supervise(0.0)
    axis.quick_stop()
    assert axis.read_state() in (AxisState.STOPPING, AxisState.DISABLED)
    axis.disable()
    assert axis.read_state() is AxisState.DISABLED


def test_feedback_is_si_in_what_the_axis_measures(target: Target) -> None:
    axis, tick = target
    axis.setup()
    axis.enable(timeout=1.0)
    for _ in range(3):
        tick()
    fb = axis.feedback()
    assert axis.measures, "an axis measures something"
    for name in ("position", "velocity", "torque", "current"):
        value = getattr(fb, name)
        assert math.isfinite(value) if name in axis.measures else math.isnan(value), name
    assert fb.stamp is not None


def test_close_is_idempotent_and_leaves_the_device_disabled(target: Target) -> None:
    axis, _ = target
    axis.setup()
    axis.enable(timeout=1.0)
    axis.close()
    axis.close()
    if axis.commandable:
        probe = _probe(axis)
        assert probe.read_state() is AxisState.DISABLED
        probe.close()


def _probe(axis: AxisDriver) -> Any:
    """A second driver on the same device (the first one is closed)."""
    if isinstance(axis, Cia402Axis):
        return Cia402Axis("probe", axis.network, axis.node_id, mode="csv")
    assert isinstance(axis, ModbusInverterAxis)
    probe = ModbusInverterAxis("probe", axis.map.name, host="127.0.0.1", port=axis.client.comm_params.port)
    probe.setup()
    return probe


def test_a_device_that_does_not_answer_is_a_toolkit_error() -> None:
    bench = LockstepBench("dc-servo")
    try:
        silent = Cia402Axis("ghost", bench.host, 9, mode="csv")  # nobody is node 9
        silent.SDO_TIMEOUT = 0.01
        silent.node.sdo.RESPONSE_TIMEOUT = 0.01
        with pytest.raises(RigError, match="node 9"):
            silent.setup()
        silent.close()
    finally:
        bench.close()
    nowhere = ModbusInverterAxis("ghost", "abb-drives-profile", host="127.0.0.1", port=1, timeout=0.1)
    with pytest.raises(CommunicationError, match=r"unit 1 at 127\.0\.0\.1:1"):
        nowhere.setup()
    nowhere.close()


def test_a_heartbeat_sent_before_the_nmt_start_does_not_stop_the_run() -> None:
    """A heartbeat in flight when the host sent NMT start (it still says PRE-OPERATIONAL) is not the
    node's answer; the next heartbeat is; a boot-up is at once (seen on the vcan tier's slow VM)."""
    bench = LockstepBench("dc-servo")
    try:
        axis = Cia402Axis("drive", bench.host, 1, mode="csv")
        axis.setup()
        device = bench.device_network
        device.send_message(cia.COB_HEARTBEAT + 1, bytes([cia.NmtState.PRE_OPERATIONAL]))
        axis.supervise(0.0)  # the stale one: tolerated
        device.send_message(cia.COB_HEARTBEAT + 1, bytes([cia.NmtState.PRE_OPERATIONAL]))
        with pytest.raises(SafetyStop, match="node 1: NMT state PRE-OPERATIONAL"):
            axis.supervise(0.0)
        axis.nmt("OPERATIONAL")
        device.send_message(cia.COB_HEARTBEAT + 1, bytes([cia.BOOT_UP]))
        with pytest.raises(SafetyStop, match="node 1: NMT state"):
            axis.supervise(0.0)
        axis.close()
    finally:
        bench.close()
