"""``rig scan``: the CANopen nodes on a bus - node id, device type, vendor, product name, NMT state.

Nodes are found with canopen's ``NodeScanner`` (an SDO upload of 0x1000 to
every node id; whoever answers is there) and by the heartbeats and boot-ups
heard while listening. Each found node is then asked by SDO for 0x1000,
0x1018:1 and 0x1008; its NMT state comes from its last heartbeat.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import canopen
from canopen.sdo.client import SdoClient

from drivers.maps import cia

__all__ = ["DEVICE_PROFILES", "scan"]

DEVICE_PROFILES = {
    401: "CiA 401 I/O",
    cia.PROFILE_DRIVE: "CiA 402 drive",
    cia.PROFILE_ENCODER: "CiA 406 encoder",
}
NMT = {state.value: state.text for state in cia.NmtState}


def scan(
    network: canopen.Network, *, listen: Callable[[], None], sdo_timeout: float = 0.1
) -> list[dict[str, Any]]:
    """Scan ``network``; ``listen()`` lets heartbeats arrive (waits, or advances emulated time)."""
    states: dict[int, int] = {}

    def on_frame(can_id: int, data: bytearray, timestamp: float) -> None:
        if data:
            states[can_id - cia.COB_HEARTBEAT] = data[0] & 0x7F  # bit 7: the toggle bit

    for node_id in range(1, 128):
        network.subscribe(cia.COB_HEARTBEAT + node_id, on_frame)
    network.scanner.search()
    listen()
    found = sorted(set(network.scanner.nodes) | set(states))
    rows = []
    for node_id in found:
        make_client: Any = SdoClient
        make_od: Any = canopen.ObjectDictionary
        client: Any = make_client(cia.COB_SDO_RX + node_id, cia.COB_SDO_TX + node_id, make_od())
        client.network = network
        client.RESPONSE_TIMEOUT = sdo_timeout
        network.subscribe(cia.COB_SDO_TX + node_id, client.on_response)
        row: dict[str, Any] = {"node_id": node_id, "nmt_state": NMT.get(states.get(node_id, -1), "unknown")}
        try:
            device_type = int.from_bytes(client.upload(cia.DEVICE_TYPE, 0), "little")
            row["device_type"] = f"0x{device_type:08X}"
            row["profile"] = DEVICE_PROFILES.get(device_type & 0xFFFF, f"CiA {device_type & 0xFFFF}")
            row["vendor_id"] = f"0x{int.from_bytes(client.upload(cia.IDENTITY, 1), 'little'):08X}"
            row["product_name"] = client.upload(cia.DEVICE_NAME, 0).decode("latin-1").rstrip("\x00")
        except (canopen.SdoAbortedError, canopen.SdoCommunicationError) as exc:
            row["error"] = str(exc)
        network.unsubscribe(cia.COB_SDO_TX + node_id, client.on_response)
        rows.append(row)
    return rows


def wall_listen(seconds: float) -> Callable[[], None]:
    """A ``listen`` that waits ``seconds`` of wall-clock time."""
    return lambda: time.sleep(seconds)
