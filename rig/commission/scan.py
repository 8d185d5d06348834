"""``rig scan``: the CANopen nodes on a bus - node id, device type, vendor, product name, NMT state.

Nodes are found with canopen's ``NodeScanner`` (an SDO upload of 0x1000 to
every node id; whoever answers is there) and by the heartbeats and boot-ups
heard while listening. Each found node is then asked by SDO for 0x1000,
0x1018:1 and 0x1008, each on its own: an object that is missing or aborts is
None in its field and one entry of ``errors`` (a node that does not answer at
all, one "no SDO answer"), and the others are still read. Its NMT state comes
from its last heartbeat. 0x1000 is decoded per CiA 301 (``profile_of``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import canopen
from canopen.sdo.client import SdoClient

from drivers.maps import cia
from drivers.maps.vendors import vendor_of

__all__ = ["DEVICE_PROFILES", "profile_of", "scan"]

#: device profile numbers (the low word of 0x1000) and their names
DEVICE_PROFILES = {
    401: "CiA 401 I/O",
    cia.PROFILE_DRIVE: "CiA 402 drive",
    404: "CiA 404 measuring",
    cia.PROFILE_ENCODER: "CiA 406 encoder",
    408: "CiA 408 hydraulic",
    410: "CiA 410 inclinometer",
    418: "CiA 418 battery",
    419: "CiA 419 charger",
}
NMT = {state.value: state.text for state in cia.NmtState}
#: what is read of each node: (JSON key, index, sub-index)
OBJECTS = (
    ("device_type", cia.DEVICE_TYPE, 0),
    ("vendor_id", cia.IDENTITY, 1),
    ("product_name", cia.DEVICE_NAME, 0),
)


def profile_of(device_type: int) -> str:
    """The device profile of a 0x1000 value (CiA 301 7.5.2.1: the low 16 bits are the profile
    number, 0 for none, the high 16 bits additional information of the profile).

    Parameters
    ----------
    device_type : int
        0x1000.

    Returns
    -------
    str
        The profile, in words.
    """
    number = device_type & 0xFFFF
    if number == 0:
        return "none given"
    return DEVICE_PROFILES.get(number, f"{number} (unknown profile)")


def _identity(client: Any, row: dict[str, Any]) -> None:
    """Fill ``row``'s object fields, each read on its own; failures into ``row["errors"]``."""
    for key, index, sub in OBJECTS:
        where = f"0x{index:04X}:{sub:02X}"
        try:
            data = client.upload(index, sub)
        except canopen.SdoAbortedError as exc:
            row["errors"].append(f"{where}: SDO abort: {exc}")
            continue
        except canopen.SdoCommunicationError:
            row["errors"].append(f"{where}: no SDO answer within {client.RESPONSE_TIMEOUT:g} s")
            return  # a node that does not answer is not asked again and again
        if key == "product_name":
            row[key] = data.decode("latin-1").rstrip("\x00")
        else:
            value = int.from_bytes(data, "little")
            row[key] = f"0x{value:08X}"
            if key == "device_type":
                row["profile"] = profile_of(value)
            else:
                row["vendor_name"] = vendor_of(value) or None  # CiA's vendor list (drivers.maps.vendors)


def _row(network: canopen.Network, node_id: int, state: int, sdo_timeout: float) -> dict[str, Any]:
    make_client: Any = SdoClient
    make_od: Any = canopen.ObjectDictionary
    client: Any = make_client(cia.COB_SDO_RX + node_id, cia.COB_SDO_TX + node_id, make_od())
    client.network = network
    client.RESPONSE_TIMEOUT = sdo_timeout
    row: dict[str, Any] = {"node_id": node_id, "nmt_state": NMT.get(state, "unknown")}
    row.update(
        {"device_type": None, "profile": None, "vendor_id": None, "vendor_name": None, "product_name": None}
    )
    row["errors"] = []
    network.subscribe(cia.COB_SDO_TX + node_id, client.on_response)
    try:
        _identity(client, row)
    finally:
        network.unsubscribe(cia.COB_SDO_TX + node_id, client.on_response)
    return row


def scan(
    network: canopen.Network, *, listen: Callable[[], None], sdo_timeout: float = 0.1
) -> list[dict[str, Any]]:
    """Scan ``network``; ``listen()`` lets heartbeats arrive (waits, or advances emulated time).
    A row per node: ``node_id``, ``nmt_state``, ``device_type``, ``profile``, ``vendor_id``, ``vendor_name``,
    ``product_name`` (None where not read) and ``errors`` (what could not be read, and why).

    Parameters
    ----------
    network : canopen.Network
        The canopen network.
    listen : Callable[[], None]
        Lets heartbeats arrive.
    sdo_timeout : float, optional
        [s] each SDO answer.

    Returns
    -------
    list[dict[str, Any]]
        One row a node.
    """
    states: dict[int, int] = {}

    def on_frame(can_id: int, data: bytearray, timestamp: float) -> None:
        if data:
            states[can_id - cia.COB_HEARTBEAT] = data[0] & 0x7F  # bit 7: the toggle bit

    for node_id in range(1, 128):
        network.subscribe(cia.COB_HEARTBEAT + node_id, on_frame)
    network.scanner.search()
    listen()
    found = sorted(set(network.scanner.nodes) | set(states))
    return [_row(network, node_id, states.get(node_id, -1), sdo_timeout) for node_id in found]


def wall_listen(seconds: float) -> Callable[[], None]:
    """A ``listen`` that waits ``seconds`` of wall-clock time."""
    return lambda: time.sleep(seconds)
