"""A CiA 402 axis's cycle plan (issue 37 item 3): made once, at set-up, for the mapping in force
(``drivers.cia402_mapping.CyclePlan``), and read as it is by every cycle: no cycle checks it
against the mapping by identity or makes it anew."""

from __future__ import annotations

import ast
import pathlib

import pytest

from drivers import cia402_mapping
from drivers.cia402 import Cia402Axis
from plant_emulator.lockstep import LockstepBench
from tests.patching import stand_in

CYCLE = pathlib.Path(__file__).resolve().parents[2] / "drivers" / "cia402_cycle.py"


def test_no_cycle_checks_its_plan() -> None:
    """``feedback``, ``supervise`` and the RPDO's packing compare neither the plan's mapping nor
    its measures to the axis's by identity (the per-cycle check made it anew where they differed)."""
    found = []
    for node in ast.walk(ast.parse(CYCLE.read_text())):
        if isinstance(node, ast.Compare) and any(isinstance(op, (ast.Is, ast.IsNot)) for op in node.ops):
            if "plan.data" in ast.unparse(node) or "plan.measures" in ast.unparse(node):
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
    assert found == []


@pytest.mark.parametrize("mode", ["voltage", "csp"])
def test_set_up_makes_the_plan_once_and_the_cycles_keep_it(
    mode: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    made: list[cia402_mapping.CyclePlan] = []
    plan = cia402_mapping.CyclePlan

    def counted(*args: object, **kw: object) -> cia402_mapping.CyclePlan:
        made.append(plan(*args, **kw))  # type: ignore[arg-type]
        return made[-1]

    stand_in(monkeypatch, "drivers.cia402_mapping.CyclePlan", counted)
    bench = LockstepBench("dc-servo")
    drive = Cia402Axis("motor", bench.host, 1, mode=mode, period=bench.period)
    try:
        assert len(made) == 1 and made[0].data is None  # the constructor's: no mapping yet
        drive.setup()
        assert len(made) == 2 and drive._plan is made[1]
        drive.enable()
        start = drive.feedback().position
        for _ in range(20):
            fb = drive.feedback()
            drive.supervise(0.0)
            drive.command(start if mode == "csp" else 1.0)
            bench.sync()
        assert fb.stamp is not None  # a sample was read
        assert len(made) == 2 and drive._plan is made[1]
    finally:
        drive.close()
        bench.close()
