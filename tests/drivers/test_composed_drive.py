"""The CiA 402 driver composed of parts (issue 37 item 3): each part owns its state in its
constructor, none is declared by a class-level annotation or a TYPE_CHECKING stub for another
class to fill. ``MIXINS_LEFT`` lists the set-up's modules still written as mixins of the axis; the
list only shrinks (it is empty: set-up's discovery, mapping and settings are parts too)."""

from __future__ import annotations

import abc
import ast
import pathlib

import canopen

from drivers.base import AxisDriver
from drivers.canopen_axis import CanopenAxis
from drivers.cia402 import Cia402Axis
from drivers.cia402_cycle import Cia402Cycle
from drivers.cia402_discovery import Cia402Discovery
from drivers.cia402_mapping import Cia402Mapping
from drivers.cia402_setup import Cia402Setup
from drivers.cia402_states import PowerStates
from drivers.cia402_supervision import DriveSupervision
from drivers.node_watch import NodeWatch
from drivers.tpdo_receiver import TpdoReceiver

DRIVERS = pathlib.Path(__file__).resolve().parents[2] / "drivers"
#: the CiA 402 driver's modules still written as mixins of the axis (this list only shrinks)
MIXINS_LEFT: set[str] = set()


def declared_state(path: pathlib.Path) -> list[str]:
    """Class-level annotations without a value and ``if TYPE_CHECKING:`` blocks in the module's
    classes, but a Protocol's (which declares what a part needs of its axis), a dataclass's and a
    NamedTuple's (whose annotations are their constructors' parameters)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.ClassDef):
            continue
        kinds = [ast.unparse(b) for b in node.bases] + [ast.unparse(d) for d in node.decorator_list]
        if any(k in ("Protocol", "NamedTuple") or k.startswith("dataclass") for k in kinds):
            continue
        for item in node.body:
            if isinstance(item, ast.AnnAssign) and item.value is None:
                found.append(f"{path.name}:{item.lineno} {node.name}.{ast.unparse(item.target)}")
            if isinstance(item, ast.If) and "TYPE_CHECKING" in ast.unparse(item.test):
                found.append(f"{path.name}:{item.lineno} {node.name}: TYPE_CHECKING")
    return found


def test_no_part_declares_its_state_for_another_to_fill() -> None:
    node = ["canopen_axis.py", "node_watch.py", "tpdo_receiver.py"]  # the CANopen node and its parts
    modules = [*(DRIVERS / name for name in node), *sorted(DRIVERS.glob("cia402*.py"))]
    found = [line for path in modules if path.name not in MIXINS_LEFT for line in declared_state(path)]
    assert found == []
    assert all(declared_state(DRIVERS / name) for name in MIXINS_LEFT)  # a module done leaves the list


def test_the_axis_composes_its_parts_and_each_owns_its_state() -> None:
    network = canopen.Network()
    axis = Cia402Axis(
        "motor",
        network,
        1,
        mode="csp",
        host=(126, 0.3),
        rpdo_deadline=0.004,
        units={"counts_per_rev": 4096.0},
        pdo="device",
        sync_rpdo=False,
        latency=0.001,
        mode_timeout=2.0,
    )
    try:
        assert isinstance(axis.states, PowerStates) and axis.states.axis is axis
        assert isinstance(axis.supervision, DriveSupervision) and axis.supervision.axis is axis
        assert vars(axis.states) == {
            "axis": axis,
            "stop_word": None,
            "disabled": False,
            "enabled_stamp": None,
            "rest_stamp": None,
        }
        watch = vars(axis.supervision)
        assert watch["host"] == (126, 0.3) and watch["rpdo_deadline"] == 0.004
        assert watch["consumer_sub"] is None and watch["deadline_comm"] is None
        assert axis._plan.data is None and axis.data is None  # the cycle's, until set-up maps
        assert Cia402Axis.__mro__[1:] == (Cia402Cycle, CanopenAxis, AxisDriver, abc.ABC, object)
        assert isinstance(axis.discovery, Cia402Discovery) and axis.discovery.axis is axis
        assert vars(axis.discovery) == {
            "axis": axis,
            "given_units": {"counts_per_rev": 4096.0},
            "units_hint": "[axis.units] {key}",
            "has_position": True,
            "supported_modes": None,
            "not_a_drive": False,
        }
        assert isinstance(axis.mapping, Cia402Mapping)
        assert vars(axis.mapping) == {"axis": axis, "pdo": "device", "sync_rpdo": False, "latency": 0.001}
        assert isinstance(axis.settings, Cia402Setup)
        assert vars(axis.settings) == {"axis": axis, "mode_timeout": 2.0}
        # the CANopen node's parts (issue 37 item 5's split): its watch and the TPDOs it receives
        assert isinstance(axis.watch, NodeWatch) and isinstance(axis.tpdos, TpdoReceiver)
        assert vars(axis.watch) == {
            "axis": axis,
            "fault": None,
            "emcy_log": [],
            "heartbeats": 0,
            "booted": False,
            "foreign_rpdo": None,
        }
        assert vars(axis.tpdos) == {"axis": axis, "slots": []}
    finally:
        axis.close()
