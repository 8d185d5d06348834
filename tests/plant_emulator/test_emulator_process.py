"""The emulator in its own process (``rig emulate``), reached through python-can's socketcand client."""

from __future__ import annotations

import contextlib
import io
import re
from collections.abc import Iterator

import can
import canopen
import pytest

from drivers.maps import CIA402_EDS
from rig.emulator.spawn import spawn_rig, stop_rig


def test_emulator_in_a_separate_process() -> None:
    proc, line = spawn_rig("emulate", "--preset", "dc-servo", "--node", "5", "--port", "0", stderr=True)
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
    proc, line = spawn_rig("emulate", "--modbus-map", "delta-vfd-b", "--port", str(port), stderr=True)
    try:
        assert f"TCP 127.0.0.1:{port}" in line, line
        inverter = ModbusInverterAxis("inverter", "delta-vfd-b", host="127.0.0.1", port=port)
        import time

        deadline = time.monotonic() + 30.0  # a guard: it prints before it listens, and may need a moment
        while True:
            try:
                inverter.setup()
                break
            except CommunicationError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        assert inverter.read("fault_code") == 0.0
        inverter.close()
    finally:
        out, err = stop_rig(proc, timeout=10)
    assert "stopped" in out, err


@contextlib.contextmanager
def _epos4_twin() -> Iterator[canopen.RemoteNode]:
    """``rig emulate --device epos4 --node 3`` in its own process, and a plain canopen client's
    node 3 on it (its own EDS)."""
    from plant_emulator.device_profile import load_profile, zoo

    proc, line = spawn_rig("emulate", "--device", "epos4", "--node", "3", "--port", "0", stderr=True)
    try:
        match = re.search(r"socketcand://127\.0\.0\.1:(\d+)", line)
        assert match and "epos4 (node 3)" in line, line
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
            eds = load_profile(zoo()["epos4"]).eds
            source = io.StringIO(eds.read_text())
            source.name = eds.name
            node = canopen.RemoteNode(3, canopen.import_od(source, 3))
            network.add_node(node)
            yield node
        finally:
            network.disconnect()
    finally:
        _out, err = stop_rig(proc, timeout=10)
    assert proc.returncode == 0, err


def test_a_zoo_twin_in_a_separate_process_answers_as_its_drive() -> None:
    """``rig emulate --device epos4``: the twin answers a plain canopen client with its own
    identity and units."""
    with _epos4_twin() as node:
        assert node.sdo[0x1018][1].raw == 0xFB
        assert node.sdo[0x60A9].raw == 0x00B44700  # rpm


@pytest.mark.timing  # the twin's motor on its own (wall) clock, waited for with deadlines
def test_a_zoo_twin_in_a_separate_process_runs_on_its_clock() -> None:
    """The twin's motor runs in real time with no SYNC at all."""
    import time

    with _epos4_twin() as node:
        node.nmt.state = "OPERATIONAL"
        node.sdo[0x6060].raw = 9  # CSV
        for _ in range(100):  # the mode-switch time passes on the twin's own clock
            if node.sdo[0x6061].raw == 9:
                break
            time.sleep(0.005)
        for cw in (0x06, 0x07, 0x0F):
            node.sdo[0x6040].raw = cw
        node.sdo[0x60FF].raw = 300  # rpm
        speeds: list[int] = []  # until five reads in a row show it at 300 rpm (it settles)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not (
            len(speeds) >= 5 and all(290 <= v <= 310 for v in speeds[-5:])
        ):
            speeds.append(node.sdo[0x606C].raw)
            time.sleep(0.02)
        assert all(290 <= v <= 310 for v in speeds[-5:]), speeds  # and no SYNC was ever sent
        node.sdo[0x6040].raw = 0x00


def test_rig_emulate_lists_the_zoo_and_refuses_bad_devices(capsys) -> None:  # type: ignore[no-untyped-def]
    from rig.cli import main

    assert main(["emulate", "--list"]) == 0
    out = capsys.readouterr().out
    assert {line.split()[0] for line in out.splitlines()} >= {"epos4", "nanotec-c5e", "erl-pcs", "drive-rig"}
    assert main(["emulate", "--device", "nosuch"]) == 2
    assert "unknown device profile 'nosuch'" in capsys.readouterr().err
    assert main(["emulate", "--device", "epos4", "--param", "bogus=1"]) == 2
    assert "unknown parameter 'bogus'" in capsys.readouterr().err
