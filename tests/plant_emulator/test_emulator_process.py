"""The emulator in its own process (``rig emulate``), reached through python-can's socketcand client."""

from __future__ import annotations

import re

import can
import canopen

from drivers.maps import CIA402_EDS
from rig.process import spawn_rig, stop_rig


def test_emulator_in_a_separate_process() -> None:
    proc, line = spawn_rig(
        "emulate", "--preset", "dc-servo", "--node-id", "5", "--socketcand-port", "0", stderr=True
    )
    try:
        match = re.search(r"socketcand://127\.0\.0\.1:(\d+)", line)
        assert match, line
        bus = can.Bus(
            interface="socketcand",
            host="127.0.0.1",
            port=int(match.group(1)),
            channel="can0",
            ignore_config=True,
        )
        network = canopen.Network(bus)
        network.connect()
        try:
            node = canopen.RemoteNode(5, CIA402_EDS)
            network.add_node(node)
            assert node.sdo[0x1000].raw == 0x00020192
            assert node.sdo[0x1018][2].raw == 0x402
            node.sdo[0x6060].raw = -1
            node.sdo[0x6040].raw = 0x06
            assert node.sdo[0x6041].raw & 0x6F == 0x21  # READY TO SWITCH ON
        finally:
            network.disconnect()
    finally:
        out, err = stop_rig(proc, timeout=10)
    assert proc.returncode == 0, err
    assert "stopped" in out


def test_modbus_inverter_process_binds_localhost_by_default() -> None:
    import socket

    from drivers.errors import CommunicationError
    from drivers.modbus_inverter import ModbusInverterAxis

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc, line = spawn_rig("emulate", "--modbus-map", "delta-vfd-b", "--modbus-port", str(port), stderr=True)
    try:
        assert f"TCP 127.0.0.1:{port}" in line, line
        inverter = ModbusInverterAxis("inverter", "delta-vfd-b", host="127.0.0.1", port=port)
        for _ in range(50):  # the server may need a moment after printing
            try:
                inverter.setup()
                break
            except CommunicationError:
                import time

                time.sleep(0.05)
        assert inverter.read("fault_code") == 0.0
        inverter.close()
    finally:
        out, err = stop_rig(proc, timeout=10)
    assert "stopped" in out, err
