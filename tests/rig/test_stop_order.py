"""Stops in the right order: no supervision a drive holds is relaxed while it is enabled.

The emulated drive (lock-step, in this process) records every SDO download it takes with the
state its statusword showed at that moment, and every RPDO with its controlword. A stop must
first bring the drive to rest and disable it, confirmed by the statusword, and only then lift
the drive's deadline on the commands (0x1400+n sub 5) or its heartbeat consumer's entry for
the host (0x1016); through the ramp the host's RPDOs keep the deadline fed, carrying the quick
stop, never enable operation. A disable the statusword does not confirm leaves both in place,
and the drive, once the host is quiet, stops itself on them.
"""

from __future__ import annotations

import dataclasses
import pathlib
from collections.abc import Iterator

import can
import pytest

from drivers.cia402 import DISABLED_STATES
from drivers.errors import CommunicationError
from drivers.maps import cia
from drivers.maps.cia import Controlword, PowerState
from plant_emulator.cia402_drive import EmulatedDrive
from rig.config import load_config
from rig.host.session import Session
from tests.rig.test_command_deadline import DEADLINE, Rig

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
RPDO_COMMS = range(cia.RPDO_COMM, cia.RPDO_COMM + 0x200)


class Record:
    """What the emulated ``drive`` took: (index, subindex, value, its state then) of each SDO
    download, and (controlword, its state then) of each RPDO."""

    def __init__(self, drive: EmulatedDrive) -> None:
        self.drive = drive
        self.writes: list[tuple[int, int, int, PowerState]] = []
        self.rpdo_words: list[tuple[int, PowerState]] = []
        own = drive.on_write

        def on_write(index: int, subindex: int, data: bytes) -> None:
            record = (int.from_bytes(data, "little"), drive.sm.state)
            if drive.in_rpdo:
                if index == cia.CONTROLWORD:
                    self.rpdo_words.append(record)
            else:
                self.writes.append((index, subindex, *record))
            own(index, subindex, data)

        drive.on_write = on_write  # type: ignore[method-assign]

    def relaxing(self) -> list[tuple[int, int, int, PowerState]]:
        """The downloads that lift a watch: an RPDO's deadline or a heartbeat consumer entry set
        to 0, an abort connection option (0x6007) written."""
        return [
            w
            for w in self.writes
            if (w[0] in RPDO_COMMS and w[1] == cia.PDO_COMM_EVENT_TIMER and w[2] == 0)
            or (w[0] == cia.CONSUMER_HEARTBEAT and w[1] and w[2] == 0)
            or w[0] == cia.ABORT_CONNECTION_OPTION
        ]


def _run(tmp_path: pathlib.Path, duration: float) -> tuple[dict, Record, list[int]]:  # type: ignore[type-arg]
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=duration))
    with Session(cfg, emulate=True) as session:
        assert session.transport.emulation is not None and session.transport.emulation.bench is not None
        drive = session.transport.emulation.bench.devices[0]
        assert isinstance(drive, EmulatedDrive)
        record = Record(drive)
        emcy: list[int] = []

        def tap(msg: can.Message) -> None:
            if msg.arbitration_id == 0x81 and len(msg.data) >= 2:
                emcy.append(msg.data[0] | msg.data[1] << 8)

        session.transport.emulation.bench.hub.taps.append(tap)
        session.start()
        summary = session.run()
    return summary, record, emcy


def test_a_run_s_stop_lifts_no_watch_before_the_statusword_shows_the_drive_disabled(
    tmp_path: pathlib.Path,
) -> None:
    """The example's servo in mid-move (0.5 s of its 1 s move, 3 V and more): its stop. Before,
    the quick stop lifted the deadline first, while the drive was OPERATION ENABLED, so a quick
    stop lost or late (an overloaded bus) left the drive on its last command with nothing to
    stop it."""
    summary, record, emcy = _run(tmp_path, 0.5)
    stop = next(k for k, w in enumerate(record.writes) if w[:2] == (cia.CONTROLWORD, 0) and w[2] == 2)
    assert record.writes[stop][3] is PowerState.OPERATION_ENABLED  # the quick stop, while enabled
    lifted = record.relaxing()[-2:]  # the stop's: the deadline and the host's consumer entry
    assert {w[0] for w in lifted} == {cia.RPDO_COMM, cia.CONSUMER_HEARTBEAT}, record.writes[stop:]
    assert all(w[3] in DISABLED_STATES for w in record.relaxing()), record.writes
    disable = record.writes.index(next(w for w in record.writes[stop:] if w[:3] == (cia.CONTROLWORD, 0, 0)))
    assert stop < disable < record.writes.index(lifted[0])
    # through the ramp the RPDOs fed the deadline with the quick stop, never enable operation
    words = [w for w, state in record.rpdo_words if state is not PowerState.OPERATION_ENABLED]
    assert words and set(words) <= {int(Controlword.QUICK_STOP), int(Controlword.DISABLE_VOLTAGE)}
    assert 0x8250 not in emcy and summary["stop_confirmed"] is True


@pytest.fixture
def refusing() -> Iterator[Rig]:
    """The toolkit's drive (voltage, its deadline and the host's heartbeat watched) that takes a
    disable voltage by SDO and does not follow it (as a drive that refuses the transition)."""
    rig = Rig("dc-servo", "voltage", DEADLINE)
    own = rig.drive._apply_controlword

    def apply(cw: int) -> None:
        if cw != Controlword.DISABLE_VOLTAGE:
            own(cw)

    rig.drive._apply_controlword = apply  # type: ignore[method-assign]
    yield rig
    rig.drive._apply_controlword = own  # type: ignore[method-assign]
    rig.close()


def test_a_disable_not_confirmed_leaves_the_drive_s_watch_and_it_stops_itself(refusing: Rig) -> None:
    """The statusword still shows OPERATION ENABLED after the disable: the deadline stays (before,
    it was lifted all the same, and the drive ran on its last command), the disable raises
    saying so, and once the host is quiet the drive's deadline trips (EMCY 0x8250) and its
    quick stop (0x6007) brings the shaft to rest."""
    rig = refusing
    rig.cycles(round(0.2 / rig.period), 3.0)
    rig.axis.DISABLE_CONFIRM = 0.0  # one look at the statusword
    with pytest.raises(CommunicationError, match=r"disable voltage not confirmed.*OPERATION ENABLED"):
        rig.axis.disable()
    assert rig.drive.read(cia.RPDO_COMM, cia.PDO_COMM_EVENT_TIMER) == 2
    assert rig.drive.sm.state is PowerState.OPERATION_ENABLED
    rig.cycles(DEADLINE + 2, None)
    assert 0x8250 in rig.emcy()
    speeds = rig.cycles(round(0.5 / rig.period), None)
    assert speeds[-1] == 0.0 and rig.drive.sm.state is PowerState.SWITCH_ON_DISABLED
