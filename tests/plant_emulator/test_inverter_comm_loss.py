"""The emulated inverter's communication-loss trip: on by default, kept away by a host that polls every
cycle (lock-step and wall clock), a ramp or coast stop with fault 0x6681 when the requests stop."""

from __future__ import annotations

import gc
import itertools
import math
import time

import pytest
from pymodbus.client import ModbusTcpClient

from drivers.errors import ConfigError
from drivers.maps import modbus_map
from plant_emulator.inverter_model import COMM_LOSS
from plant_emulator.modbus_inverter import InverterContext, InverterServer, default_model
from rig.config.emulator import inverter_values

ABB = modbus_map("abb-drives-profile")
RUN, RESET, DT = 0x047F, 0x04FE, 0.01  # ABB drives profile control words; lock-step period [s]


def running_at_50(action: str = "ramp") -> tuple[InverterContext, float]:
    """An inverter at 50 rad/s, polled every cycle up to now; the model time of the last poll [s]."""
    ctx = InverterContext(default_model("abb-drives-profile", comm_loss_action=action))
    ref = ABB["speed_reference"]
    ctx.setValues(6, ref.address, [ref.to_raw(50.0)])
    ctx.setValues(6, ABB["control_word"].address, [RUN])
    for _ in range(150):
        ctx.model.step(DT)
        ctx.getValues(3, ABB["status_word"].address)
    assert ctx.model.speed == pytest.approx(50.0, abs=0.01) and not ctx.model.fault
    return ctx, ctx.model.t


def test_on_by_default_and_checked() -> None:
    model = default_model("delta-vfd-b")
    assert model.comm_loss_timeout == 0.5 and model.comm_loss_action == "ramp"
    # its parameters are checked where they are read ([emulator.inverter], rig emulate --param)
    for bad in (0.0, -1.0):
        with pytest.raises(ConfigError, match=rf"comm_loss_timeout = {bad!r}: must be > 0 s \(inf: off\)"):
            inverter_values({"comm_loss_timeout": bad}, "FILE: [emulator.inverter]")
    with pytest.raises(ConfigError, match="comm_loss_timeout = nan: expected a number, not NaN"):
        inverter_values({"comm_loss_timeout": math.nan}, "FILE: [emulator.inverter]")
    with pytest.raises(ConfigError, match="comm_loss_action = 'brake': expected one of ramp, coast"):
        inverter_values({"comm_loss_action": "brake"}, "FILE: [emulator.inverter]")
    assert default_model("delta-vfd-b", comm_loss_timeout=math.inf).comm_loss_timeout == math.inf


def test_silence_trips_after_the_timeout_and_the_ramp_stops_the_motor() -> None:
    ctx, last = running_at_50()
    model = ctx.model
    while not model.fault:
        model.step(DT)
        assert model.t - last < 0.5 + 2 * DT, "no trip after comm_loss_timeout"
    assert model.fault == COMM_LOSS and model.t - last > 0.5 and not model.running
    status = ctx.getValues(3, ABB["status_word"].address)[0]
    assert status >> ABB.status["fault_bit"] & 1
    assert ctx.getValues(3, ABB["fault_code"].address) == [COMM_LOSS]
    speeds = []
    for _ in range(60):  # 100 rad/s^2 from 50 rad/s: at rest after 0.5 s (+ the lag tau)
        model.step(DT)
        speeds.append(model.speed)
    assert speeds[10] == pytest.approx(40.0, abs=3.0) and abs(speeds[-1]) < 1.0
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(speeds))


def test_coast_stop_cuts_the_current_and_the_speed_runs_down_freely() -> None:
    ctx, _ = running_at_50("coast")
    model = ctx.model
    while not model.fault:
        model.step(DT)
    tripped = model.t
    while model.t - tripped < 1.0 - DT / 2:
        model.step(DT)
        assert model.current == 0.0
    assert model.speed == pytest.approx(50.0 * math.exp(-1.0 / model.coast_tau), rel=0.02)
    # a fault reset and a new run command bring the modulation back, from the speed it coasted to
    ctx.setValues(6, ABB["control_word"].address, [RESET])
    ctx.setValues(6, ABB["control_word"].address, [RUN])
    ctx.model.step(DT)
    assert not model.fault and model.running and not model.coasting and model.current > 0.0


@pytest.mark.timing  # a poll every 10 ms on the wall clock keeps it running: not under any load
def test_wall_clock_a_polling_host_keeps_it_running_and_silence_trips_it() -> None:
    model = default_model("abb-drives-profile")
    with InverterServer(model, dt=0.002) as server:
        client = ModbusTcpClient("127.0.0.1", port=server.port, timeout=5.0)
        assert client.connect()
        assert not client.write_register(ABB["speed_reference"].address, 4000, device_id=1).isError()
        assert not client.write_register(ABB["control_word"].address, RUN, device_id=1).isError()
        start = last = time.monotonic()
        while last - start < 1.5:  # three timeouts of a 10 ms poll: no trip
            time.sleep(0.01)
            assert not client.read_holding_registers(3, count=3, device_id=1).isError()
            last = time.monotonic()  # the last request was served by now
        assert model.running and not model.fault
        while not model.fault and time.monotonic() < last + 10.0:  # waits for the trip, decides nothing
            time.sleep(0.005)
        # 0.5 s after the last request (``last`` is a little later: the answer had to come back)
        assert model.fault == COMM_LOSS and time.monotonic() - last > 0.4
        client.close()
    gc.collect()
