"""An emulated device constructs its state before any of its hooks can run (issue 37 item 3): the
node's set-up (``EmulatedNode.__init__``) calls no hook, the first is ``boot``'s power-on, and no
hook asks whether its own state exists yet (``hasattr(self, ...)``)."""

from __future__ import annotations

import ast
import pathlib

import canopen
import pytest

from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.device_profile import device_profile
from plant_emulator.presets import build_twin

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_no_device_asks_whether_its_own_state_exists_yet() -> None:
    found = []
    for path in sorted((ROOT / "plant_emulator").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
                asks = node.func.id == "hasattr" or (node.func.id == "getattr" and len(node.args) == 3)
                if asks and ast.unparse(node.args[0]) == "self":
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert found == []


@pytest.mark.parametrize("name", ["drive-rig", "dual-axis"])
def test_construction_runs_no_hook_and_power_on_finds_every_axis(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    called: list[str] = []
    reset = EmulatedDrive.on_reset

    def on_reset(self: EmulatedDrive, *, application: bool) -> None:
        called.append(type(self).__name__)
        reset(self, application=application)

    monkeypatch.setattr(EmulatedDrive, "on_reset", on_reset)
    network = canopen.Network()
    network.connect(interface="virtual", channel=f"construction-{name}")
    try:
        (drive,), _ = build_twin(device_profile(name), network)
        assert called == []
        assert isinstance(drive, EmulatedDrive)
        drive.boot()
    finally:
        network.disconnect()
    assert len(called) == device_profile(name).axes
