"""The emulated Modbus inverter with pymodbus clients as the peer: TCP, and RTU over a pty pair;
served by coroutines (``rig emulate``) and by the ``InverterServer`` handle."""

from __future__ import annotations

import asyncio
import gc
import math
import socket
import time

import pytest
from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException
from pymodbus.framer import FramerType

from drivers.maps import modbus_map
from plant_emulator.modbus_inverter import (
    OVERSPEED,
    InverterContext,
    InverterServer,
    default_model,
    serve_rtu,
    serve_tcp,
)
from plant_emulator.pty_link import PtyLink


def test_register_semantics_lock_step() -> None:
    """Control, reference, status and exceptions through the context, with the physics stepped by hand."""
    model = default_model("abb-drives-profile")
    ctx = InverterContext(model)
    ref = modbus_map("abb-drives-profile")["speed_reference"]
    assert ctx.setValues(6, ref.address, [ref.to_raw(50.0)]) is None
    assert ctx.setValues(6, 0, [0x047F]) is None  # run
    for _ in range(100):
        model.step(0.01)
        ctx.getValues(3, 3)  # the host's poll every cycle keeps the communication-loss trip away
    speed = modbus_map("abb-drives-profile")["actual_speed"]
    assert speed.to_si(ctx.getValues(3, speed.address)[0]) == pytest.approx(50.0, abs=0.01)
    status = ctx.getValues(3, 3)[0]
    assert status & 0x0107 == 0x0107  # ready, running, at setpoint
    assert ctx.setValues(6, 3, [0]).value == 2  # read-only: illegal data address
    assert ctx.getValues(3, 50).value == 2  # unknown register
    assert ctx.setValues(6, ref.address, [ref.to_raw(150.0)]) is None
    assert ctx.setValues(6, ref.address, [0x7FFF]).value == 3  # 257 rad/s > max speed: illegal value
    assert ctx.setValues(5, 0, [1]).value == 1  # coils: illegal function


def test_delta_map_runs_and_trips() -> None:
    model = default_model("delta-vfd-b", max_speed=60.0)
    ctx = InverterContext(model)
    reg = modbus_map("delta-vfd-b")
    f = reg["speed_reference"]
    assert ctx.setValues(6, f.address, [f.to_raw(80.0)]).value == 3  # above max speed
    ctx.setValues(6, f.address, [f.to_raw(59.0)])
    ctx.setValues(6, reg["control_word"].address, [0x12])  # run forward
    for _ in range(200):
        model.step(0.01)
        ctx.getValues(3, reg["status_word"].address)  # the host's poll
    assert ctx.getValues(3, reg["status_word"].address)[0] & 0x3 == 0x3
    model.load = lambda t: -10.0  # a driving load pushes the motor over its limit
    for _ in range(100):
        model.step(0.01)
        ctx.getValues(3, reg["status_word"].address)
    assert model.fault == OVERSPEED
    assert ctx.getValues(3, reg["fault_code"].address)[0] != 0
    ctx.setValues(6, reg["fault_control"].address, [0x2])  # reset
    assert ctx.getValues(3, reg["fault_code"].address)[0] == 0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_tcp_server_with_pymodbus_client() -> None:
    async def run() -> None:
        port = _free_port()
        model = default_model("abb-drives-profile")
        server = asyncio.create_task(serve_tcp(model, port=port, dt=0.001))
        client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=2)
        for _ in range(100):
            if await client.connect():
                break
            await asyncio.sleep(0.02)
        assert not (await client.write_register(1, 2000, device_id=1)).isError()
        assert not (await client.write_register(0, 0x047F, device_id=1)).isError()
        bad = await client.write_register(4, 1, device_id=1)
        assert bad.isError() and bad.exception_code == 2
        rr = await client.read_holding_registers(0, count=6, device_id=1)
        assert rr.registers[:2] == [0x047F, 2000] and rr.registers[3] & 0x4
        client.close()
        server.cancel()
        await asyncio.gather(server, return_exceptions=True)

    asyncio.run(run())
    gc.collect()  # any socket left open warns here, in this test


def test_rtu_over_a_pty_pair() -> None:
    async def run(link: PtyLink) -> None:
        model = default_model("delta-vfd-b")
        server = asyncio.create_task(serve_rtu(model, port=link.port_a, baudrate=19200, unit=3, dt=0.001))
        client = AsyncModbusSerialClient(
            link.port_b, framer=FramerType.RTU, baudrate=19200, timeout=1, retries=1
        )
        assert await client.connect()
        reg = modbus_map("delta-vfd-b")
        f = reg["speed_reference"]
        # a request before the server has opened its end is lost (pyserial's open empties the
        # input): asked until answered (a condition; the deadline only guards against a hang)
        deadline = asyncio.get_running_loop().time() + 30.0
        while True:
            try:
                if not (await client.read_holding_registers(f.address, count=1, device_id=3)).isError():
                    break
            except ModbusException:
                pass
            assert asyncio.get_running_loop().time() < deadline, "serve_rtu never answered"
        assert not (await client.write_register(f.address, f.to_raw(2 * math.pi * 10), device_id=3)).isError()
        rr = await client.read_holding_registers(f.address, count=1, device_id=3)
        assert f.to_si(rr.registers[0]) == pytest.approx(2 * math.pi * 10, abs=0.04)
        bad = await client.write_register(reg["current"].address, 5, device_id=3)
        assert bad.isError() and bad.exception_code == 2
        client.close()
        server.cancel()
        await asyncio.gather(server, return_exceptions=True)

    with PtyLink() as link:
        asyncio.run(run(link))
    gc.collect()


def test_inverter_server_handle_over_tcp_in_lock_step() -> None:
    """dt=None: nothing moves until the owner steps the model; start/stop from plain code."""
    from pymodbus.client import ModbusTcpClient

    model = default_model("abb-drives-profile")
    speed = modbus_map("abb-drives-profile")["actual_speed"]
    with InverterServer(model) as server:
        assert server.port > 0
        with pytest.raises(RuntimeError, match="already started"):
            server.start()
        client = ModbusTcpClient("127.0.0.1", port=server.port, timeout=2)
        assert client.connect()
        assert not client.write_register(1, 2000, device_id=1).isError()  # 20 % of the speed range
        assert not client.write_register(0, 0x047F, device_id=1).isError()  # run
        assert client.read_holding_registers(speed.address, count=1, device_id=1).registers == [0]
        for _ in range(100):
            model.step(0.01)  # the owner's lock-step, a poll each cycle as the host makes
            assert not client.read_holding_registers(3, count=1, device_id=1).isError()
        reading = speed.to_si(client.read_holding_registers(speed.address, count=1, device_id=1).registers[0])
        assert reading == pytest.approx(model.speed, abs=0.01) and model.speed > 10.0
        client.close()
    server.stop()  # idempotent
    refused = ModbusTcpClient("127.0.0.1", port=server.port, timeout=0.5, retries=0)
    assert not refused.connect()
    refused.close()
    gc.collect()


def test_inverter_server_with_wall_clock_physics_and_a_busy_port() -> None:
    model = default_model("delta-vfd-b")
    with InverterServer(model, dt=0.002) as server:
        deadline = time.monotonic() + 10.0
        while model.t == 0.0 and time.monotonic() < deadline:  # waits for the physics, decides nothing
            time.sleep(0.005)
        assert model.t > 0.0
        with pytest.raises(OSError, match="Modbus inverter server"):
            InverterServer(default_model("delta-vfd-b"), port=server.port, timeout=5.0).start()
    gc.collect()


def test_inverter_server_handle_over_rtu_on_a_pty_pair() -> None:
    from pymodbus.client import ModbusSerialClient

    reg = modbus_map("delta-vfd-b")
    f = reg["speed_reference"]
    with PtyLink() as link, InverterServer(default_model("delta-vfd-b"), serial=link.port_a, unit=3):
        client = ModbusSerialClient(link.port_b, framer=FramerType.RTU, baudrate=19200, timeout=1, retries=1)
        assert client.connect()
        assert not client.write_register(f.address, f.to_raw(2 * math.pi * 10), device_id=3).isError()
        rr = client.read_holding_registers(f.address, count=1, device_id=3)
        assert f.to_si(rr.registers[0]) == pytest.approx(2 * math.pi * 10, abs=0.04)
        client.close()
    with pytest.raises(OSError, match="Modbus inverter server: Could not start listen"):
        InverterServer(default_model("delta-vfd-b"), serial="/dev/no-such-tty", timeout=5.0).start()
    gc.collect()
