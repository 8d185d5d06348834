"""The run's CAN trace: the same lines as python-can's ASCWriter, and python-can's ASCReader reads them;
or python-can's BLF, read back by its BLFReader."""

from __future__ import annotations

import pathlib

import can
import pytest

from rig.host.trace import AscTrace
from tests.rig.test_zoo_runs import SLACK

FRAMES = [
    can.Message(timestamp=100.0, arbitration_id=0x80, data=b"", is_extended_id=False, channel="host"),
    can.Message(timestamp=100.0004, arbitration_id=0x281, data=bytes(range(8)), is_extended_id=False),
    can.Message(
        timestamp=100.0008,
        arbitration_id=0x201,
        data=b"\x0f\x00\xe8\x03",
        is_extended_id=False,
        channel="emulator",
        is_rx=False,
    ),
    can.Message(timestamp=100.0012, arbitration_id=0x18FF1234, data=b"\x01", is_extended_id=True),
    can.Message(timestamp=100.0016, arbitration_id=0x701, is_remote_frame=True, dlc=1, is_extended_id=False),
    can.Message(timestamp=100.0020, arbitration_id=0x701, data=b"\x05", is_extended_id=False, channel="can1"),
    can.Message(timestamp=100.0024, is_error_frame=True),
    can.Message(timestamp=100.0028, arbitration_id=0x181, data=b"\x01", dlc=2, is_extended_id=False),
    can.Message(timestamp=112.5, arbitration_id=0x181, data=b"\x01\x02", is_extended_id=False),  # 10 s on
]


def _lines(path: pathlib.Path) -> list[str]:
    return [line for line in path.read_text().splitlines() if not line.startswith(("date", "Begin"))]


def test_the_fast_path_writes_python_cans_lines(tmp_path: pathlib.Path) -> None:
    ours, theirs = tmp_path / "ours.asc", tmp_path / "theirs.asc"
    for path, cls in ((ours, AscTrace), (theirs, can.ASCWriter)):
        writer = cls(str(path))
        for msg in FRAMES:
            writer.on_message_received(msg)
        writer.stop()
    assert _lines(ours) == _lines(theirs)
    read = list(can.ASCReader(str(ours)))
    assert [m.arbitration_id for m in read if not m.is_error_frame] == [
        m.arbitration_id for m in FRAMES if not m.is_error_frame
    ]
    assert read[1].data == bytes(range(8)) and abs(read[1].timestamp - 0.0004) < 1e-9


def test_the_header_s_milliseconds_have_three_digits(tmp_path: pathlib.Path) -> None:
    """python-can writes .62 for 62 ms, which its reader takes for 620 ms; ours writes .062."""
    path = tmp_path / "t.asc"
    start = 1_790_000_000.062  # [s] a wall-clock time 62 ms into its second
    writer = AscTrace(str(path))
    writer.on_message_received(can.Message(timestamp=start, arbitration_id=0x80, is_extended_id=False))
    writer.on_message_received(can.Message(timestamp=start + 0.5, arbitration_id=0x181, data=b"\x01"))
    writer.stop()
    assert ".062 " in next(line for line in path.read_text().splitlines() if line.startswith("Begin"))
    read = list(can.ASCReader(str(path), relative_timestamp=False))
    assert abs(read[0].timestamp - start) < 1e-3 and abs(read[1].timestamp - start - 0.5) < 1e-3


def test_an_emulated_run_s_trace_has_both_directions(tmp_path: pathlib.Path) -> None:
    import dataclasses

    from rig.config import load_config
    from rig.host.session import Session

    cfg = load_config(pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml")
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=0.1))
    with Session(cfg, emulate=True) as session:
        session.start()
        summary = session.run()
    frames = list(can.ASCReader(str(pathlib.Path(summary["run_dir"]) / "trace.asc")))
    tx = {m.arbitration_id for m in frames if not m.is_rx}
    rx = {m.arbitration_id for m in frames if m.is_rx}
    assert {0x80, 0x201, 0x601, 0x000} <= tx  # SYNC, RPDO1, SDO requests, NMT: the host's
    assert {0x181, 0x581} <= rx and not tx & {0x181, 0x581}  # TPDO1, SDO responses: the drive's


def _seen(m: can.Message) -> tuple[int, bytes, bool, bool]:
    """What a reader gives back of a frame: id, the DLC's bytes (a remote frame: none), direction."""
    data = b"" if m.is_remote_frame else bytes(m.data).ljust(m.dlc, b"\0")[: m.dlc]
    return m.arbitration_id, data, m.is_rx, m.is_remote_frame


@pytest.mark.parametrize("kind", ["asc", "blf"])
def test_the_recorder_s_trace_reads_back_in_python_can_s_reader(kind: str, tmp_path: pathlib.Path) -> None:
    """``[run] trace = "asc" | "blf"``: the frames given to the recorder come back from python-can's
    ASCReader or BLFReader (a reader nobody here wrote) with their ids, data, direction and times;
    ``"none"`` writes no trace."""
    from rig.host.recorder import Recorder

    recorder = Recorder(tmp_path, "t", trace=kind)
    for msg in FRAMES:
        recorder.on_frame(msg)
    recorder.close({})
    path = recorder.dir / f"trace.{kind}"
    reader = can.ASCReader(str(path)) if kind == "asc" else can.BLFReader(str(path))
    read = [m for m in reader if not m.is_error_frame]
    sent = [m for m in FRAMES if not m.is_error_frame]
    assert list(map(_seen, read)) == list(map(_seen, sent))
    assert [round(m.timestamp - read[0].timestamp, 6) for m in read] == [
        round(m.timestamp - sent[0].timestamp, 6) for m in sent
    ]
    none = Recorder(tmp_path, "none", trace="none")
    none.on_frame(FRAMES[0])
    none.close({})
    assert none.trace is None and not list(none.dir.glob("trace.*"))


def test_a_run_with_trace_blf_writes_trace_blf(tmp_path: pathlib.Path) -> None:
    """``[run] trace = "blf"`` in the example's file: the run's trace.blf, read by python-can's
    BLFReader, has the host's frames as Tx and the drive's as Rx, and there is no trace.asc."""
    from rig.config import load_config
    from rig.host.session import Session

    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    text = example.read_text().replace('output = "runs"', f'trace = "blf"\noutput = "{tmp_path}"', 1)
    (tmp_path / "blf.toml").write_text(text.replace("duration = 3.0", "duration = 0.1"))
    cfg = load_config(tmp_path / "blf.toml")
    assert cfg.run.trace == "blf"
    with Session(cfg, emulate=True) as session:
        session.start()
        summary = session.run()
    run_dir = pathlib.Path(summary["run_dir"])
    frames = list(can.BLFReader(str(run_dir / "trace.blf")))
    assert not (run_dir / "trace.asc").exists() and len(frames) > summary["cycles"]
    tx = {m.arbitration_id for m in frames if not m.is_rx}
    rx = {m.arbitration_id for m in frames if m.is_rx}
    assert {0x80, 0x201, 0x601, 0x000} <= tx and {0x181, 0x581} <= rx and not tx & {0x181, 0x581}


@pytest.mark.timing
def test_a_trace_over_a_real_bus_holds_the_host_s_frames_at_the_right_time(tmp_path: pathlib.Path) -> None:
    """``rig run`` in real time over socketcand to ``rig emulate`` in another process: the
    frames the host sends (its SYNC every period, RPDOs, SDO requests) are in the trace as Tx,
    the drive's as Rx, at absolute times within the run."""
    import dataclasses
    import json
    import re

    from plant_emulator.device_profile import load_profile, zoo
    from rig.config import BusConfig, load_config, replace_axis
    from rig.emulator.spawn import spawn_rig, stop_rig
    from rig.host.session import Session

    proc, line = spawn_rig("emulate", "--device", "epos4", "--port", "0", stderr=True)
    try:
        port = int(re.search(r"socketcand://127\.0\.0\.1:(\d+)", line).group(1))  # type: ignore[union-attr]
        cfg = load_config(pathlib.Path(__file__).resolve().parents[2] / "examples" / "zoo_csp_position.toml")
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(
                cfg.run, output=str(tmp_path), time="realtime", period=0.002, duration=0.4
            ),
            bus=BusConfig(interface="socketcand", channel="can0", port=port),
            reference=dataclasses.replace(cfg.reference, distance=1.0, duration=0.2),
        )
        eds = str(load_profile(zoo()["epos4"]).eds)
        cfg = replace_axis(cfg, "motor", eds=eds, enable_timeout=3.0, sdo_timeout=2.0, limits=SLACK)
        with Session(cfg, emulate=False) as session:
            session.start()
            summary = session.run()
    finally:
        stop_rig(proc, timeout=10)
    run_dir = pathlib.Path(summary["run_dir"])
    frames = list(can.ASCReader(str(run_dir / "trace.asc"), relative_timestamp=False))
    syncs = [m for m in frames if m.arbitration_id == 0x80]
    assert syncs and all(not m.is_rx for m in syncs)
    assert len(syncs) >= summary["cycles"]  # one per cycle, and those of the stop
    assert any(not m.is_rx and m.arbitration_id == 0x601 for m in frames)  # SDO requests
    assert any(m.is_rx and m.arbitration_id == 0x581 for m in frames)  # SDO responses
    started = json.loads((run_dir / "started.json").read_text())["wall_time"]
    first_sync = next(m for m in syncs).timestamp
    assert started - 30.0 < frames[0].timestamp <= first_sync <= started + 30.0  # the right date


def test_a_frame_the_host_receives_is_rx_whatever_the_kernel_says() -> None:
    """python-can's socketcan marks a frame that another socket of the same machine sent (every
    frame on a vcan, an emulator on the host's own can0) ``is_rx=False``: the trace wrote the
    drive's answers as Tx, and candump disagreed (found by the interop tier)."""
    from rig.host.trace import received

    seen: list[can.Message] = []
    listener = received(seen.append)
    listener(can.Message(arbitration_id=0x581, data=bytes(8), is_extended_id=False, is_rx=False))
    listener(can.Message(arbitration_id=0x181, data=bytes(4), is_extended_id=False))
    assert [m.is_rx for m in seen] == [True, True]


def test_an_answer_is_traced_after_the_request_it_answers() -> None:
    """The drive's answer reaches the receive thread while the sender is between its send and
    its tap: the answer must still come after the request in the trace (the interop tier saw
    an SDO answer before its request; candump had them the right way round)."""
    import threading

    from rig.host.trace import TracedNetwork, received

    trace: list[tuple[int, bool]] = []
    network = TracedNetwork()
    network.tx_tap = lambda m: trace.append((m.arbitration_id, m.is_rx))
    on_received = received(network.tx_tap, network.trace_lock)

    class Bus:  # the answer arrives during the send: a receive thread traces it at once
        def send(self, msg: can.Message, timeout: float | None = None) -> None:
            answer = can.Message(arbitration_id=0x581, data=bytes(8), is_extended_id=False)
            receiver = threading.Thread(target=on_received, args=(answer,))
            receiver.start()
            receiver.join(timeout=0.5)  # it cannot trace before the request: it waits for the lock
            self.receiver = receiver

    bus = network.bus = Bus()  # type: ignore[assignment]
    network.send_message(0x601, bytes(8))
    bus.receiver.join(timeout=10)
    assert trace == [(0x601, False), (0x581, True)]


def test_the_trace_hears_a_frame_before_canopen_does() -> None:
    """canopen's listener wakes the SDO client, which sends its next request at once: a trace
    listener after it wrote that request before the answer that caused it (the interop tier saw
    it against candump). The trace's listener goes first, and leaves no trace of itself."""
    from rig.host.trace import TracedNetwork, attach_received, detach_received

    network = TracedNetwork()
    network.connect(interface="virtual", channel="trace-order", receive_own_messages=False)
    try:
        canopen_listeners = list(network.notifier.listeners)
        listener = attach_received(network, lambda m: None)
        assert network.notifier.listeners == [listener, *canopen_listeners]
        detach_received(network, listener)
        assert network.notifier.listeners == canopen_listeners
    finally:
        network.disconnect()
