"""``rig lss`` against an LSS slave nobody here wrote: durand's (PyPI, MIT; Günther Jena), a CANopen
responder written from CiA 301/305 on python-can alone, sharing no code with python-canopen, whose
LSS master ``rig lss`` drives and on which the emulator's slave is built. canopen's master against
the emulator's slave is tests/plant_emulator/test_lss_slave.py; here the same master, through
rig lss's own steps (``rig.cli.lss``), configures durand's node from the box (node-ID 255): it finds
it by identify non-configured remote slave and fastscan, inquires its identity, gives it a node-ID
and hears it boot with it; the bit rate and the store, which a durand node refuses unless its
application installs a handler for them, come back as CiA 305's error in words.

durand talks to a ``NetworkABC``; ``DurandOnHub`` is one on the lock-step hub (``SyncHub``), so the
frames go both ways within each send, deterministic and without vcan. durand answers identify
remote slave with 0x47 where CiA 305 has 0x4F; rig lss does not use that service.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from typing import Any

import can
import pytest

from plant_emulator.lockstep import SyncHub, SyncNetwork, attach_network
from rig.cli.lss import _act
from rig.commission.lss import Address, LssTool
from tests.interop.conftest import unavailable

pytestmark = pytest.mark.interop

ADDRESS = Address(0x00ABCDEF, 0x00000305, 0x00020001, 0x12345678)


def _durand() -> Any:
    try:
        import durand
    except ImportError:
        unavailable("durand is not installed (pip install -e '.[interop]')")
    return durand


class DurandOnHub:
    """durand's ``NetworkABC`` on a ``SyncHub``: its subscriptions get the hub's frames."""

    def __init__(self, hub: SyncHub) -> None:
        self.bus = hub.bus(queue=False, channel="durand")
        self.subscriptions: dict[int, Callable[[int, bytes], None]] = {}
        self.bus.listeners.append(self._heard)

    def _heard(self, msg: can.Message) -> None:
        callback = self.subscriptions.get(msg.arbitration_id)
        if callback is not None and not msg.is_remote_frame:
            callback(msg.arbitration_id, bytes(msg.data))

    def add_subscription(self, cob_id: int, callback: Callable[[int, bytes], None]) -> None:
        self.subscriptions[cob_id] = callback

    def remove_subscription(self, cob_id: int) -> None:
        self.subscriptions.pop(cob_id, None)

    def send(self, cob_id: int, msg: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=cob_id, data=msg, is_extended_id=False))


@pytest.fixture
def durand_node() -> Iterator[tuple[Any, LssTool, list[tuple[int, bytes]]]]:
    """A durand node fresh from the box (node-ID 255) and rig lss's tool beside it on one hub."""
    durand = _durand()
    from durand.scheduler import SyncScheduler

    durand.set_scheduler(SyncScheduler())  # nothing it does here is timed: never run
    hub = SyncHub()
    frames: list[tuple[int, bytes]] = []
    hub.taps.append(lambda m: frames.append((m.arbitration_id, bytes(m.data))))
    network: Any = DurandOnHub(hub)
    node = durand.MinimalNode(network, 0xFF)
    for sub, value in enumerate((ADDRESS.vendor, ADDRESS.product, ADDRESS.revision, ADDRESS.serial), 1):
        node.object_dictionary.write(0x1018, sub, value)
    host = SyncNetwork()
    attach_network(host, hub.bus(queue=False, channel="host"))
    try:
        yield node, LssTool(host, timeout=0.01), frames
    finally:
        host.bus.shutdown()
        network.bus.shutdown()


def _args(action: str, **kw: Any) -> argparse.Namespace:
    base = {"action": action, "store": False, "reset": False, "stop": False, "fastscan": False}
    return argparse.Namespace(**(base | kw))


def test_rig_lss_finds_and_configures_a_durand_node(durand_node: Any) -> None:
    node, tool, frames = durand_node
    out = _act(tool, _args("scan"), None)
    assert out["unconfigured"] == 1 and out["select"] == ADDRESS.text() and out["node_id"] == 255
    frames.clear()
    out = _act(tool, _args("node-id", node_id=7, fastscan=True), None)
    assert out["selected_by"] == f"fastscan {ADDRESS.text()}"
    assert (out["vendor"], out["product"], out["revision"], out["serial"]) == tuple(
        f"0x{n:08X}" for n in (ADDRESS.vendor, ADDRESS.product, ADDRESS.revision, ADDRESS.serial)
    )
    assert (out["node_id_was"], out["node_id"], out["booted"]) == (255, 7, True)
    assert node.node_id == 7 and (0x707, b"\x00") in frames  # durand's own boot-up as node 7
    assert tool.unconfigured() == 0
    out = _act(tool, _args("inquire"), ADDRESS)  # switch state selective, durand's 0x44 answer
    assert out["selected_by"] == f"switch state selective {ADDRESS.text()}" and out["node_id"] == 7


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (
            _args("bitrate", kbit=500),
            "configure bit timing 500 kbit/s: the slave answered bit rate not supported",
        ),
        (
            _args("store"),
            "store configuration: the slave answered storing the configuration is not supported",
        ),
    ],
)
def test_what_durand_refuses_comes_back_in_cia_305_words(
    durand_node: Any, args: argparse.Namespace, said: str
) -> None:
    _, tool, _ = durand_node
    with pytest.raises(Exception, match=said):
        _act(tool, args, ADDRESS)
