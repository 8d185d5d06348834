"""``rig lss``: a drive's node-ID and bit rate set over the bus (CiA 305 layer setting services),
through canopen's LSS master (``network.lss``), as EPOS Studio's and TwinCAT's LSS pages do.

``LssTool`` puts one slave in the LSS configuration state, by one of CiA 305's three ways:
``select`` (switch state selective: its four 0x1018 entries, answered by that slave only),
``fastscan`` (the unconfigured slave of lowest address, found bit by bit), or, by default, switch
state global, which puts every LSS slave on the bus in the configuration state: right only with
one drive on the bus, and a second answer to an inquiry is refused as such. Then it inquires the
slave's identity and node-ID, configures a node-ID or a bit rate (CiA 305's table), stores the
configuration in the slave's non-volatile memory, and switches every slave back to the waiting
state. A node-ID configured is the slave's at its next NMT reset communication; a slave that had
none (255) takes it when switched back to waiting, and boots with it: ``wait_boot`` waits for that
boot-up (0x700 + node-ID, byte 0).

canopen raises ``LssError`` with its own words; here each is the toolkit's error: no answer is a
``CommunicationTimeout`` naming the service and what to do, an answer's error code is a
``CommunicationError`` in CiA 305's words (``drivers.maps.lss.error_text``).
"""

from __future__ import annotations

import contextlib
import queue
import re
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from canopen.lss import LssError

from drivers.errors import CommunicationError, CommunicationTimeout, ConfigError
from drivers.maps.cia import BOOT_UP, COB_HEARTBEAT, COB_NMT, NmtCommand
from drivers.maps.lss import BIT_TIMINGS, Cs, error_text

__all__ = ["Address", "LssTool", "bit_timing"]

_SECOND = 0.02  #: [s] a second slave's answer to the same inquiry is looked for this long
_SELECT_HINT = (
    "with more than one LSS slave on the bus, select one: --select ADDRESS (rig lss scan finds an "
    "unconfigured one's) or --fastscan"
)


@dataclass(frozen=True)
class Address:
    """An LSS address: 0x1018 sub 1-4."""

    vendor: int  #: 0x1018 sub 1
    product: int  #: 0x1018 sub 2
    revision: int  #: 0x1018 sub 3
    serial: int  #: 0x1018 sub 4

    @classmethod
    def parse(cls, text: str) -> Address:
        """``VENDOR:PRODUCT:REVISION:SERIAL``, each decimal or 0x hex; ValueError naming ``text``.

        Parameters
        ----------
        text : str
            ``VENDOR:PRODUCT:REVISION:SERIAL``.

        Returns
        -------
        Address
            The address.

        Raises
        ------
        ValueError
            If ``text`` is not one (it named).
        """
        parts = text.split(":")
        try:
            numbers = [int(p, 0) for p in parts]
        except ValueError:
            numbers = []
        if len(numbers) != 4 or not all(0 <= n <= 0xFFFFFFFF for n in numbers):
            raise ValueError(
                f"{text!r} is not VENDOR:PRODUCT:REVISION:SERIAL (four 32-bit numbers, 0x allowed)"
            )
        return cls(*numbers)

    def text(self) -> str:
        """``0x000000FB:0x65520000:0x00010000:0x00000001``: what ``--select`` takes.

        Returns
        -------
        str
            The address as ``--select`` takes it.
        """
        return ":".join(f"0x{n:08X}" for n in (self.vendor, self.product, self.revision, self.serial))

    def as_dict(self) -> dict[str, str]:
        """JSON-ready: each number in hex.

        Returns
        -------
        dict[str, str]
            The address.
        """
        keys = ("vendor", "product", "revision", "serial")
        return {
            k: f"0x{n:08X}" for k, n in zip(keys, (self.vendor, self.product, self.revision, self.serial))
        }


def bit_timing(kbit: int) -> int:
    """CiA 305's table index of ``kbit`` [kbit/s]; ValueError naming the rates it has.

    Parameters
    ----------
    kbit : int
        [kbit/s].

    Returns
    -------
    int
        The table index.

    Raises
    ------
    ValueError
        If the rate is not in the table.
    """
    for index, rate in BIT_TIMINGS.items():
        if rate == kbit * 1000:
            return index
    known = ", ".join(str(r // 1000) for r in sorted(BIT_TIMINGS.values(), reverse=True))
    raise ValueError(f"{kbit} kbit/s is not in CiA 305's bit timing table ({known} kbit/s)")


class LssTool:
    """One LSS master's services on ``network`` (a connected canopen ``Network``); each answer is
    awaited ``timeout`` [s].

    Parameters
    ----------
    network : Any
        A connected canopen ``Network``.
    timeout : float, optional
        [s] for each answer.
    """

    def __init__(self, network: Any, *, timeout: float = 0.5) -> None:
        self.network = network
        self.lss = network.lss
        self.lss.RESPONSE_TIMEOUT = timeout
        self.timeout = timeout
        self.selected_by = ""  #: how the slave was put in the configuration state

    @contextlib.contextmanager
    def _said(self, what: str, cs: int) -> Iterator[None]:
        """canopen's LssError of service ``cs`` (``what``) as the toolkit's error."""
        try:
            yield
        except LssError as exc:
            text = str(exc)
            code = re.fullmatch(r"LSS Error: (\d+)", text)
            if code:
                raise CommunicationError(
                    f"LSS {what}: the slave answered {error_text(cs, int(code[1]))}"
                ) from exc
            if "No LSS response" in text:
                raise CommunicationTimeout(
                    f"LSS {what}: no LSS slave answered within {self.timeout:g} s: none is in the "
                    f"configuration state, or none on this bus speaks LSS; {_SELECT_HINT}"
                ) from exc
            raise CommunicationError(f"LSS {what}: {text} (another LSS master on the bus?)") from exc

    # --- into and out of the configuration state --------------------------------------------
    def select(self, address: Address) -> None:
        """Switch state selective: the slave of ``address`` only (CommunicationTimeout: none has it).

        Parameters
        ----------
        address : Address
            The slave's.

        Raises
        ------
        CommunicationTimeout
            If no slave has it.
        """
        try:
            with self._said("switch state selective", Cs.SELECT_SERIAL):
                self.lss.send_switch_state_selective(
                    address.vendor, address.product, address.revision, address.serial
                )
        except CommunicationTimeout as exc:
            raise CommunicationTimeout(
                f"LSS: no slave has the address {address.text()} (rig lss scan lists an unconfigured one's; "
                "a configured one's is its 0x1018)"
            ) from exc
        self.selected_by = f"switch state selective {address.text()}"

    def fastscan(self) -> Address:
        """The unconfigured slave of lowest address, found by fastscan, put in the configuration
        state (CommunicationTimeout: no unconfigured slave answered).

        Returns
        -------
        Address
            Its address.

        Raises
        ------
        CommunicationTimeout
            If no unconfigured slave answered.
        """
        with self._said("fastscan", Cs.FASTSCAN):
            found, numbers = self.lss.fast_scan()
        if not found or numbers is None:
            raise CommunicationTimeout(
                f"LSS fastscan: no unconfigured slave (node-ID 255) answered within {self.timeout:g} s"
            )
        address = Address(*numbers)
        self.selected_by = f"fastscan {address.text()}"
        return address

    def all_slaves(self) -> None:
        """Switch state global to configuration: every LSS slave on the bus."""
        self.lss.send_switch_state_global(self.lss.CONFIGURATION_STATE)
        self.selected_by = "switch state global (every LSS slave)"

    def leave(self) -> None:
        """Switch state global to waiting: a slave that had no node-ID takes the one configured."""
        self.lss.send_switch_state_global(self.lss.WAITING_STATE)

    # --- services of the configuration state ------------------------------------------------
    def inquire(self) -> dict[str, Any]:
        """The slave's identity (0x1018 sub 1-4) and its node-ID (255: none), each in hex.
        ConfigError where a second slave answered (switch state global with two on the bus).

        Returns
        -------
        dict[str, Any]
            ``vendor``, ``product``, ``revision``, ``serial`` and ``node_id``.
        """
        found: dict[str, Any] = {}
        for key, cs in (
            ("vendor", Cs.INQUIRE_VENDOR),
            ("product", Cs.INQUIRE_VENDOR + 1),
            ("revision", Cs.INQUIRE_VENDOR + 2),
            ("serial", Cs.INQUIRE_SERIAL),
        ):
            with self._said(f"inquire identity ({key})", cs):
                found[key] = f"0x{self.lss.inquire_lss_address(cs):08X}"
            self._alone(f"inquire identity ({key})")
        with self._said("inquire node-ID", Cs.INQUIRE_NODE_ID):
            found["node_id"] = self.lss.inquire_node_id()
        return found

    def _alone(self, what: str) -> None:
        """ConfigError where another slave's answer came behind the one taken."""
        try:
            self.lss.responses.get(timeout=min(self.timeout, _SECOND))
        except queue.Empty:
            return
        raise ConfigError(f"LSS {what}: more than one LSS slave answered; {_SELECT_HINT}")

    def node_id(self, node: int) -> None:
        """Configure node-ID ``node`` (1..127, or 255: none).

        Parameters
        ----------
        node : int
            1..127, or 255.
        """
        with self._said(f"configure node-ID {node}", Cs.CONFIGURE_NODE_ID):
            self.lss.configure_node_id(node)

    def bitrate(self, kbit: int) -> None:
        """Configure the bit rate ``kbit`` [kbit/s] (CiA 305's table).

        Parameters
        ----------
        kbit : int
            [kbit/s].
        """
        with self._said(f"configure bit timing {kbit} kbit/s", Cs.CONFIGURE_BIT_TIMING):
            self.lss.configure_bit_timing(bit_timing(kbit))

    def activate(self, delay_ms: int) -> None:
        """Activate bit timing: the slaves switch after ``delay_ms`` [ms], and send nothing for as
        long again (no answer).

        Parameters
        ----------
        delay_ms : int
            [ms].
        """
        self.lss.activate_bit_timing(delay_ms)

    def store(self) -> None:
        """Store configuration: the node-ID and bit rate configured, in the slave's memory."""
        with self._said("store configuration", Cs.STORE_CONFIGURATION):
            self.lss.store_configuration()

    # --- the waiting state ---------------------------------------------------------------------
    def unconfigured(self) -> int:
        """How many slaves without a node-ID answer identify non-configured remote slave (each
        answer awaited ``timeout``).

        Returns
        -------
        int
            Slaves answering.
        """
        self.lss.send_identify_non_configured_remote_slave()
        count = 0
        while True:
            try:
                answer = self.lss.responses.get(timeout=self.timeout)
            except queue.Empty:
                return count
            count += answer[:1] == bytes([Cs.NON_CONFIGURED_SLAVE])

    def boot_watch(self, node: int) -> threading.Event:
        """An event set by the boot-up of node ``node`` (heartbeat COB-ID, state 0), from now on.

        Parameters
        ----------
        node : int
            The node.

        Returns
        -------
        threading.Event
            The event.
        """
        booted = threading.Event()

        def heard(can_id: int, data: bytes, timestamp: float) -> None:
            if bytes(data[:1]) == bytes([BOOT_UP]):
                booted.set()

        self.network.subscribe(COB_HEARTBEAT + node, heard)
        return booted

    def reset_communication(self, node: int) -> None:
        """NMT reset communication of node ``node``: it takes the node-ID pending.

        Parameters
        ----------
        node : int
            The node.
        """
        self.network.send_message(COB_NMT, bytes([NmtCommand.RESET_COMMUNICATION, node]))

    def stop_all(self) -> None:
        """NMT stop remote node to every node (some drives answer LSS only in NMT STOPPED)."""
        self.network.send_message(COB_NMT, bytes([NmtCommand.STOP, 0]))
