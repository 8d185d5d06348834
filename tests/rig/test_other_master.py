"""A second master on the bus is found before anything is enabled, and, while running, an RPDO to one
of the host's nodes that it did not send, or a SYNC while the host produces it, is a safe stop
named as such.

In this process: the independent fake device (``tests/drivers/fake_device.py``) on python-can's
virtual bus, which delivers a frame to every bus on the channel but its sender's, as SocketCAN and
socketcand do; the other master is a third bus on the channel. Across processes (timing tier):
``rig emulate`` behind socketcand with two ``rig run`` hosts on it."""

from __future__ import annotations

import contextlib
import json
import pathlib
import re
import subprocess
import sys
from collections.abc import Iterator

import can
import canopen
import pytest

from drivers.master_watch import MasterWatch, OtherMaster
from rig.config import load_config
from rig.host.session import Session
from tests.drivers.foreign import ForeignDrive, until

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "zoo_csp_position.toml"


@pytest.fixture
def drive(tmp_path: pathlib.Path) -> Iterator[ForeignDrive]:
    d = ForeignDrive("faulhaber-mc5004", tmp_path)
    yield d
    d.close()


def _config(tmp_path: pathlib.Path, d: ForeignDrive, *, sync: str = "host") -> pathlib.Path:
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path / "runs"}"')
    time = "lockstep" if sync == "host" else "realtime"  # an external SYNC paces a real-time run
    text = text.replace("[run]", f'[run]\nperiod = 0.001\ntime = "{time}"', 1)
    text = text.replace('interface = "socketcand"', 'interface = "virtual"')
    text = text.replace('channel = "can0"', f'channel = "{d.channel}"\nsync = "{sync}"')
    text = text.replace('[emulator]\ndevice = "epos4"\n', "").replace(
        'mode = "csp"', f'mode = "csp"\neds = "{d.eds}"'
    )
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("cob", "data", "said"),
    [
        (0x080, b"", r"heard SYNC 0x080 at [\d.]+ Hz \(3 frames in [\d.]+ s\), which this host did not send"),
        (0x201, bytes(6), r"heard RPDO to node 1 0x201 at [\d.]+ Hz \(3 frames"),
        (0x000, b"\x01\x01", r"heard NMT command 0x000 \(start node 1\) at"),
    ],
)
def test_another_master_is_refused_before_anything_is_written(
    drive: ForeignDrive, tmp_path: pathlib.Path, cob: int, data: bytes, said: str
) -> None:
    with Session(load_config(_config(tmp_path, drive)), emulate=False, cycles=20) as session:
        for _ in range(3):
            drive.send(cob, data)
        watch = session.transport.master_watch
        assert watch is not None
        until(lambda: watch.heard.get(cob, [0])[0] == 3, "the three frames heard")
        with pytest.raises(OtherMaster, match=said) as err:
            session.start()
    assert ('set [bus] sync = "external"' in str(err.value)) == (cob == 0x080)
    assert "nothing was enabled" in str(err.value) and "\n" not in str(err.value)
    assert (
        drive.fake.downloads == [] and drive.fake.uploads == [] and drive.fake.state == "SWITCH ON DISABLED"
    )
    assert not (tmp_path / "runs").exists()  # nothing was reached: no run


def test_an_external_sync_is_shared(drive: ForeignDrive, tmp_path: pathlib.Path) -> None:
    """``[bus] sync = "external"``: a SYNC from another device is the rig's pacing, not a master."""
    with Session(load_config(_config(tmp_path, drive, sync="external")), emulate=False, cycles=20) as session:
        drive.send(0x080, b"")
        session.start()
        assert drive.fake.state == "OPERATION ENABLED"


@pytest.mark.parametrize(
    ("cob", "data", "said"),
    [
        (0x201, bytes(6), r"RPDO to node 1 0x201 \(1 frame\)"),
        (0x080, b"", r"SYNC 0x080 \(1 frame\)"),  # a second SYNC producer, while the host's SYNC runs
    ],
)
def test_a_foreign_rpdo_or_sync_while_running_is_a_safe_stop(
    drive: ForeignDrive, tmp_path: pathlib.Path, cob: int, data: bytes, said: str
) -> None:
    with Session(load_config(_config(tmp_path, drive)), emulate=False, cycles=200) as session:
        session.start()
        drive.fake.inject[drive.fake.syncs + 50] = (cob, data)  # before that SYNC's TPDOs
        summary = session.run()
    assert 45 <= summary["cycles"] <= 55, summary["cycles"]
    reason = summary["safe_stop_reason"]
    assert re.search(rf"node 1: another master on the bus: {said}, which this host did not send", reason)
    assert summary["stop_confirmed"] is True and drive.fake.state == "SWITCH ON DISABLED"


def test_a_foreign_rpdo_heard_after_the_last_cycle_s_check_is_named(
    drive: ForeignDrive, tmp_path: pathlib.Path
) -> None:
    """An RPDO of another master that reaches the host after its last cycle's supervision, before
    the stop: the run's last look (``HostLoop.run``) names it; the run is not reported as clean."""
    cycles = 20

    def last(k: int) -> None:  # after the last cycle's commands (every cycle's progress, at 20)
        if k == cycles:
            drive.send(0x201, bytes(6))
            until(lambda: 0x201 in watch.heard, "the frame heard")

    with Session(load_config(_config(tmp_path, drive)), emulate=False, cycles=cycles) as session:
        watch = session.transport.master_watch
        session.start()
        summary = session.run(progress=last)
    assert summary["cycles"] == cycles
    reason = summary["safe_stop_reason"]
    assert reason is not None and re.search(
        r"node 1: another master on the bus: RPDO to node 1 0x201 \(1 frame\), which this host did not send",
        reason,
    ), reason
    assert summary["stop_confirmed"] is True and drive.fake.state == "SWITCH ON DISABLED"


def test_rig_drive_checks_before_it_enables(drive: ForeignDrive) -> None:
    from rig.commission.drive import DriveTool

    net = drive.network()
    watch = MasterWatch(net, [1])
    tool = DriveTool(drive.axis("csp", network=net), watch=watch)
    drive.send(0x080, b"")
    until(lambda: 0x080 in watch.heard, "the SYNC heard")
    from rig.commission import moves

    jog = lambda: moves.jog(tool, 1.0, 0.1, max_speed=5.0)  # noqa: E731
    move = lambda: moves.move(tool, 0.1, max_travel=1.0)  # noqa: E731
    for action in (tool.enable, jog, move):
        with pytest.raises(OtherMaster, match=r"rig drive: another master is on the bus: heard SYNC 0x080"):
            action()
    assert [w for w in drive.fake.downloads if w[0] in (0x6040, 0x6060)] == []
    assert drive.fake.nmt_log == []


@contextlib.contextmanager
def running_host(tmp_path: pathlib.Path, duration: float) -> Iterator[tuple[subprocess.Popen[str], int, str]]:
    """``rig emulate`` (the EPOS4 twin) behind socketcand and host A, a real-time ``rig run`` of
    ``duration`` [s] on it with ``--json``, once its run is under way: (host A, port, the EDS);
    both stopped after the block if still running."""
    from plant_emulator.device_profile import load_profile, zoo
    from rig.emulator.spawn import spawn_emulator, stop_rig
    from rig.faults.wire import CONFIG, PERIOD
    from rig.faults.wire_probe import wait_for

    eds = load_profile(zoo()["epos4"]).eds
    emulator, port = spawn_emulator("--device", "epos4")
    host: subprocess.Popen[str] | None = None
    try:
        text = CONFIG.format(
            duration=duration, period=PERIOD, out=tmp_path / "a", port=port, eds=eds, speed=20.0
        )
        (tmp_path / "a.toml").write_text(text.replace("speed = 250.0\n", "speed = 250.0\nwatchdog = 1.0\n"))
        host = subprocess.Popen(
            [sys.executable, "-m", "rig.cli", "run", "--config", str(tmp_path / "a.toml"), "--json"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        wait_for(lambda: any((tmp_path / "a").glob("*/samples.csv")), 30.0, "host A's run")
        wait_for(
            lambda: next((tmp_path / "a").glob("*/samples.csv")).stat().st_size > 4096, 30.0, "A running"
        )
        yield host, port, eds
    finally:
        if host is not None and host.poll() is None:
            stop_rig(host, timeout=20)
        _out, err = stop_rig(emulator, timeout=20)
    assert emulator.returncode == 0, err


@pytest.mark.timing
def test_a_second_host_is_refused_across_processes(tmp_path: pathlib.Path) -> None:
    """``rig emulate`` (the EPOS4 twin) behind socketcand; host A runs it in real time; host B, a
    second ``rig run`` on the same node, hears A's SYNC and RPDOs and is refused before it sends a
    frame; A's run goes on undisturbed to its end."""
    from rig.faults.wire import CONFIG, PERIOD

    with running_host(tmp_path, 8.0) as (host_a, port, eds):
        text_b = CONFIG.format(
            duration=2.0, period=PERIOD, out=tmp_path / "b", port=port, eds=eds, speed=20.0
        )
        (tmp_path / "b.toml").write_text(text_b)
        for _ in range(5):  # python-can's socketcand client refuses a '< ok >' that frames follow in
            b = subprocess.run(  # the same read (a busy bus): that open is tried again
                [sys.executable, "-m", "rig.cli", "run", "--config", str(tmp_path / "b.toml")],
                capture_output=True,
                text=True,
                timeout=60,
                check=False,
            )
            if "Expected '< ok >'" not in b.stderr:
                break
        assert b.returncode == 1, b.stderr
        assert re.search(
            r"another master is on the bus: heard SYNC 0x080 at [\d.]+ Hz \(\d+ frames in [\d.]+ s\), "
            r"RPDO to node 1 0x201 at [\d.]+ Hz",
            b.stderr,
        ), b.stderr
        assert 'set [bus] sync = "external"' in b.stderr and len(b.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "b").exists()
        out, err = host_a.communicate(timeout=60)
        summary = json.loads(out)
        assert summary["safe_stop_reason"] is None, (summary["safe_stop_reason"], err[-2000:])


def test_the_host_s_own_frames_echoed_by_its_adapter_are_not_another_master(drive: ForeignDrive) -> None:
    """Some adapters give the host back every frame it sent (a candleLight's gs_usb firmware echoes
    each one; ICS neoVI's default, python-can's udp_multicast): its own NMT commands and RPDOs are
    heard on its own bus. They are not another master; another node's RPDO still is."""
    net = canopen.Network(can.Bus(interface="virtual", channel=drive.channel, receive_own_messages=True))
    net.NOTIFIER_CYCLE = 0.02
    net.connect()
    drive._networks.append(net)
    watch = MasterWatch(net, [1])
    watch.check(0.0)
    axis = drive.axis("csv", network=net, units={"counts_per_rev": 4096}, period=0.001)
    axis.setup()
    watch.add_rpdo(axis.data.rpdo.cob_id, 1)  # type: ignore[union-attr]
    axis.master_watch = watch
    axis.enable()
    for _ in range(5):
        axis.command(1.0)
    until(lambda: len(drive.fake.rpdos) >= 5, "five RPDOs taken")
    until(lambda: watch.heard or watch.echoes_seen >= 5, "the echoes heard")
    axis.supervise(0.0)  # fails without the echoes told apart: 'NMT command 0x000 (start node 1)'
    assert watch.heard == {}
    drive.send(0x201, bytes(6))  # another master's RPDO on the same bus
    until(lambda: 0x201 in watch.heard, "the other master's RPDO")
    with pytest.raises(
        OtherMaster, match=r"node 1: another master on the bus: RPDO to node 1 0x201 \(1 frame\)"
    ):
        axis.supervise(0.0)


@pytest.mark.timing
def test_a_second_sync_producer_stops_a_run_across_processes(tmp_path: pathlib.Path) -> None:
    """``rig emulate`` (the EPOS4 twin) behind socketcand; ``rig run`` drives it in real time with
    its own SYNC; another client of the same bus sends one SYNC: the run ends in a safe stop
    naming it, confirmed (the drive disabled at rest), exit 3."""
    from drivers.socketcand_client import SocketcandBus

    with running_host(tmp_path, 20.0) as (host, port, _eds):
        other = SocketcandBus("can0", "127.0.0.1", port, timeout=3.0)
        try:
            other.send(can.Message(arbitration_id=0x080, data=b"", is_extended_id=False))
            out, err = host.communicate(timeout=60)
        finally:
            other.shutdown()
    assert host.returncode == 3, err[-2000:]
    summary = json.loads(out)
    reason = summary["safe_stop_reason"]
    assert re.search(r"node 1: another master on the bus: SYNC 0x080 \(1 frame\), which this", reason)
    assert summary["stop_confirmed"] is True, summary["still_turning"]
