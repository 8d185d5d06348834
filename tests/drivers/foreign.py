"""A drive of another vendor on python-can's virtual bus, for the driver's tests: the independent
``fake_device.FakeDrive`` serving one of ``dictionaries/``, the EDS it comes with, and the host's
networks and axes on the same virtual channel (each test its own channel)."""

from __future__ import annotations

import pathlib
import time
import uuid
from collections.abc import Callable
from typing import Any

import can
import canopen

from drivers.cia402 import Cia402Axis
from tests.drivers.fake_device import Dictionary, FakeDrive

#: every dictionary of the folder (``cia402-common`` is the objects they share, not a drive)
DICTIONARIES = sorted(
    p.stem
    for p in (pathlib.Path(__file__).parent / "dictionaries").glob("*.toml")
    if p.stem != "cia402-common"
)


class ForeignDrive:
    """Dictionary ``name`` served at node 1 on a fresh virtual channel; ``eds`` in ``folder``."""

    def __init__(self, name: str, folder: pathlib.Path) -> None:
        self.dictionary = Dictionary.load(name)
        self.eds = str(self.dictionary.write_eds(folder))
        self.channel = f"fake-{uuid.uuid4().hex}"
        self.fake = FakeDrive(self.dictionary, self.channel)
        self._networks: list[Any] = []
        self._axes: list[Cia402Axis] = []

    def network(self) -> Any:
        net = canopen.Network(can.Bus(interface="virtual", channel=self.channel))
        net.NOTIFIER_CYCLE = 0.02  # its receive thread ends within that on disconnect
        net.connect()
        self._networks.append(net)
        return net

    def axis(self, mode: str, **kw: Any) -> Cia402Axis:
        kw.setdefault("sdo_timeout", 2.0)  # a thread answers: generous under load, never waited out
        network = kw.pop("network", None)  # a Network is a mapping: empty (no node yet), it is falsy
        kw.setdefault("eds", self.eds)  # eds=None: no EDS of the device's own (the toolkit's generic one)
        axis = Cia402Axis("motor", self.network() if network is None else network, 1, mode=mode, **kw)
        self._axes.append(axis)
        return axis

    def send(self, cob_id: int, data: bytes) -> None:
        """A frame from a third node (another master) on the channel."""
        with can.Bus(interface="virtual", channel=self.channel) as bus:
            bus.send(can.Message(arbitration_id=cob_id, data=data, is_extended_id=False))

    def close(self) -> None:
        for axis in self._axes:
            axis.close()
        for net in self._networks:
            net.disconnect()
        self.fake.close()

    def __enter__(self) -> ForeignDrive:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def until(done: Callable[[], bool], what: str, timeout: float = 5.0) -> None:
    """Wait for the fake's thread to have done ``done`` (a bound on a frame's way, not a timing)."""
    end = time.monotonic() + timeout
    while not done():
        if time.monotonic() > end:
            raise AssertionError(f"not within {timeout} s: {what}")
        time.sleep(0.002)
