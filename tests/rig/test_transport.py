"""The transport seam (issue 37 item 1): the session composes a transport, the axes, a law and a
recorder without asking which transport it has, and reaches the axes through their contract only.
"""

from __future__ import annotations

import ast
import dataclasses
import pathlib
import re
import warnings

import pytest

from drivers.base import AxisDriver, AxisState, Feedback
from rig.config import load_config
from rig.host.pacing import FreeRun, InProcessLockstep
from rig.host.session import Session
from rig.host.timebase import Timebase
from rig.host.transport import ModbusOnly
from rig.host.transports import open_transport

ROOT = pathlib.Path(__file__).resolve().parents[2]
HOST = ROOT / "rig" / "host"
#: the kinds of axis and of transport an isinstance would ask about
_KIND = re.compile(r"Axis|Transport|Emulat|CanBus|ModbusOnly|Network")


def _tree(name: str) -> ast.Module:
    return ast.parse((HOST / name).read_text())


@pytest.mark.parametrize("name", sorted(p.name for p in HOST.glob("session*.py")))
def test_the_session_asks_no_transport_which_it_is(name: str) -> None:
    """No isinstance of an axis or a transport, no hasattr in the session (and the parts it builds,
    ``session_parts.py``), no test of emulation or time mode, no private attribute of another object
    (an axis's ``_forget``/``_release``)."""
    found = []
    for node in ast.walk(_tree(name)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            kinds = ast.unparse(node.args[1]) if len(node.args) > 1 else ""
            if node.func.id == "hasattr" or (node.func.id == "isinstance" and _KIND.search(kinds)):
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
        if isinstance(node, (ast.If, ast.IfExp)):
            test = ast.unparse(node.test)
            if any(word in test for word in ("emulat", "lockstep", 'realtime"', ".time ==", "interface")):
                found.append(f"line {node.lineno}: if {test}")
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
            if not (isinstance(node.value, ast.Name) and node.value.id == "self"):
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
    assert found == []


def test_the_loop_reads_its_timebase_and_asks_no_axis_its_kind() -> None:
    """The loop keeps no copy of the timebase's period or time mode (``self.period``,
    ``self.realtime``), and knows whether an axis stamps on the wall clock from the driver contract
    (``AxisDriver.wall_stamps``), not by an isinstance."""
    found = []
    for node in [*ast.walk(_tree("loop.py")), *ast.walk(_tree("cycle_step.py"))]:
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "isinstance":
            if len(node.args) > 1 and _KIND.search(ast.unparse(node.args[1])):
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            if ast.unparse(node) in ("self.period", "self.realtime"):
                found.append(f"line {node.lineno}: {ast.unparse(node)} =")
    assert found == []


@pytest.mark.parametrize("name", ["session.py", "loop.py"])
def test_session_and_loop_are_under_300_lines(name: str) -> None:
    lines = len((HOST / name).read_text().splitlines())
    assert lines < 300, f"rig/host/{name}: {lines} lines"


class _Axis(AxisDriver):
    """An axis that counts what it was asked."""

    def __init__(self) -> None:
        super().__init__("a", "csv")
        self.asked: list[str] = []

    @property
    def where(self) -> str:
        return "here"

    def setup(self) -> None:
        self.asked.append("setup")

    def enable(self, *, timeout: float = 1.0) -> None:
        self.asked.append("enable")

    def disable(self) -> None:
        self.asked.append("disable")

    def quick_stop(self) -> None:
        self.asked.append("quick_stop")

    def feedback(self) -> Feedback:
        return Feedback()

    def read_state(self) -> AxisState:
        return AxisState.UNKNOWN

    def _release(self) -> None:
        self.asked.append("release")


def test_abandon_releases_without_touching_the_device() -> None:
    """``abandon`` (another master's drive): released, no disable; closed after it, once."""
    axis = _Axis()
    axis.abandon()
    axis.abandon()
    axis.close()
    assert axis.asked == ["release"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResourceWarning)
        axis.__del__()  # closed: no 'never closed' warning


def test_idle_is_the_contracts() -> None:
    """Every axis has ``idle`` (what its waits call), a short sleep until the host sets it."""
    axis = _Axis()
    axis.idle()
    ticks: list[int] = []
    axis.idle = lambda: ticks.append(1)
    axis.idle()
    assert ticks == [1]
    axis.close()


def test_each_transport_paces_and_idles_its_own_way(tmp_path: pathlib.Path) -> None:
    """The emulated world: lock-step by its SYNC, set-up's idle a SYNC; Modbus only: free-running
    on the loop's deadlines, no idle. The session's pacing is the transport's."""
    cfg = load_config(ROOT / "examples" / "dc_servo_position.toml")
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    with Session(cfg, emulate=True, cycles=3) as session:
        assert session.transport.idle() is not None
        session.start()
        assert isinstance(session.pacing, InProcessLockstep)
        session.run()
    modbus = load_config(ROOT / "examples" / "modbus_inverter_speed.toml")
    transport = open_transport(modbus, Timebase(0.01, lockstep=False), emulate=False)
    try:
        assert isinstance(transport, ModbusOnly)
        assert transport.idle() is None and isinstance(transport.pacing([]), FreeRun)
    finally:
        transport.close()
