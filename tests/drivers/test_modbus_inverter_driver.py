"""The host's Modbus inverter driver: the unit ids each line allows, and exception answers as errors
that name the register, its role, the unit and the exception (against the emulated inverter)."""

from __future__ import annotations

import gc
from collections.abc import Iterator

import pytest

from drivers.base import AxisState
from drivers.errors import ConfigError, ModbusExceptionResponse
from drivers.modbus_inverter import ModbusInverterAxis
from plant_emulator.modbus_inverter import InverterServer, default_model

MAP = "abb-drives-profile"


@pytest.mark.parametrize(
    ("where", "unit", "message"),
    [
        ({"serial": "/dev/ttyS0"}, 0, r"unit 0 is not 1\.\.247 on RTU \(0 is the broadcast address"),
        ({"serial": "/dev/ttyS0"}, 248, r"unit 248 is not 1\.\.247 on RTU"),
        ({"host": "127.0.0.1"}, 256, r"unit 256 is not 0\.\.255 on TCP"),
        ({"host": "127.0.0.1"}, -1, r"unit -1 is not 0\.\.255 on TCP"),
    ],
)
def test_units_a_line_cannot_address(where: dict[str, str], unit: int, message: str) -> None:
    with pytest.raises(ConfigError, match=rf"axis 'inverter': Modbus {message}"):
        ModbusInverterAxis("inverter", MAP, unit=unit, **where)  # type: ignore[arg-type]


@pytest.fixture
def server() -> Iterator[InverterServer]:
    with InverterServer(default_model(MAP), unit=1) as served:
        yield served
    gc.collect()


@pytest.mark.parametrize("unit", [1, 0, 0xFF])
def test_tcp_units_of_a_directly_addressed_server(server: InverterServer, unit: int) -> None:
    axis = ModbusInverterAxis("inverter", MAP, unit=unit, host="127.0.0.1", port=server.port)
    try:
        axis.setup()
        axis.enable(timeout=2.0)
        axis.command(10.0)
        assert axis.feedback().velocity == 0.0 and axis.read_state() is AxisState.ENABLED
    finally:
        axis.close()


def test_an_exception_answer_names_role_register_unit_and_code(server: InverterServer) -> None:
    axis = ModbusInverterAxis("inverter", MAP, host="127.0.0.1", port=server.port)
    try:
        axis.setup()
        with pytest.raises(ModbusExceptionResponse) as info:
            axis.write("speed_reference", 220.0)  # above the inverter's 200 rad/s: illegal data value
        assert info.value.code == 3 and info.value.register == 1
        expected = "writing speed_reference (unit 1, register 1, exception code 3: illegal data value)"
        assert f"exception answer {expected}" in str(info.value)
    finally:
        axis.close()


def test_a_unit_the_server_is_not_answers_0b_named(server: InverterServer) -> None:
    axis = ModbusInverterAxis("inverter", MAP, unit=7, host="127.0.0.1", port=server.port)
    try:
        with pytest.raises(ModbusExceptionResponse, match="reading status_word") as info:
            axis.setup()
        assert info.value.code == 0x0B and "gateway target device failed to respond" in str(info.value)
    finally:
        axis.close()


def test_a_unit_that_cannot_be_reached_is_one_line_and_not_disabled_on_close(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Nothing listens: setup says it cannot connect, naming host:port; close does not then try
    (and fail) to disable the unit it never reached, which was a second line."""
    import logging
    import socket

    from drivers.errors import CommunicationError

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    axis = ModbusInverterAxis("inverter", "abb-drives-profile", host="127.0.0.1", port=port)
    with caplog.at_level(logging.WARNING, logger="drivers"), pytest.raises(CommunicationError) as err:
        try:
            axis.setup()
        finally:
            axis.close()
    assert f"127.0.0.1:{port}: cannot connect" in str(err.value)
    assert "is the inverter on and serving there?" in str(err.value)  # the likely cause, and the fix
    assert "rig emulate --modbus-map NAME" in str(err.value)
    assert not [r for r in caplog.records if r.name.startswith("drivers")]  # pymodbus's: rig silences
