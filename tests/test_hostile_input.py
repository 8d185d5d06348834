"""Hostile input, generated: each gives a clear toolkit error (or is handled), never a traceback,
and never moves the motor. 1,000 cases per kind in the slow tier (``-m slow``), 100 in the
default run (each kind's 1,000 took 5-26 s of CPU, a fifth of the default run's)."""

from __future__ import annotations

import json
import math
import pathlib
import tempfile
from typing import Any

import can
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.cia402 import Cia402Axis
from drivers.errors import CommunicationError, ConfigError, ModbusExceptionResponse
from drivers.maps import CIA402_EDS
from drivers.maps.od import load_od
from drivers.modbus_inverter import ModbusInverterAxis
from plant_emulator.cia402_state import PowerState
from plant_emulator.lockstep import LockstepBench
from rig.config import load_config
from rig.host.session import build_law

CASES = settings(deadline=None, suppress_health_check=list(HealthCheck))
#: each test runs its kind's cases twice: a few in the default run, 1,000 in the slow tier
TIERS = pytest.mark.parametrize(
    "cases", [pytest.param(100, id="100"), pytest.param(1000, id="1000", marks=pytest.mark.slow)]
)
SECTIONS = ["run", "bus", "emulator", "axis", "controller", "reference", "faults", "plant", "Run"]
KEYS = [
    "duration",
    "time",
    "period",
    "name",
    "interface",
    "channel",
    "preset",
    "node_id",
    "mode",
    "sync_rpdo",
    "kind",
    "a_m",
    "b_m",
    "lam",
    "sigma",
    "h",
    "u0",
    "kp",
    "ki",
    "distance",
    "value",
    "speed",
    "command",
    "watchdog_periods",
    "frame_loss",
    "tpdo_stall_at",
    "eds",
    "latency",
    "reads",
    "commands",
    "limits",
    "units",
    "profile",
    "x",
    "",
]
scalars = st.one_of(
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.text(max_size=20),
    st.sampled_from(["lockstep", "realtime", "voltage", "position-servo", "pi-speed", "dq-current", "csv"]),
)
values = st.one_of(
    scalars, st.lists(scalars, max_size=3), st.dictionaries(st.sampled_from(KEYS), scalars, max_size=3)
)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"


@TIERS
def test_configuration_files(cases: int) -> None:
    settings(CASES, max_examples=cases)(given(DOCS)(_configuration_file))()


DOCS = st.dictionaries(
    st.sampled_from(SECTIONS), st.dictionaries(st.sampled_from(KEYS), values, max_size=6), max_size=6
)


def _configuration_file(doc: dict[str, dict[str, Any]]) -> None:
    text = "\n".join(
        ("[[axis]]" if section == "axis" else f"[{section}]")
        + "\n"
        + "\n".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in table.items())
        for section, table in doc.items()
    )
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "rig.toml"
        path.write_text(text)
        try:
            cfg = load_config(path)
            build_law(cfg, 0.001)
        except ConfigError as exc:
            assert str(path) in str(exc) or "[controller]" in str(exc) or "[reference]" in str(exc)


@TIERS
def test_configuration_text(cases: int) -> None:
    settings(CASES, max_examples=cases)(given(st.text(max_size=200))(_configuration_text))()


def _configuration_text(text: str) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "rig.toml"
        path.write_bytes(text.encode("utf-8", "replace"))
        try:
            load_config(path)
        except ConfigError as exc:
            assert str(path) in str(exc)


EDS_LINES = pathlib.Path(CIA402_EDS).read_text().splitlines()


@TIERS
def test_eds_files(cases: int) -> None:
    mutations = (
        st.lists(st.integers(0, len(EDS_LINES) - 1), max_size=8),
        st.lists(st.tuples(st.integers(0, len(EDS_LINES) - 1), st.text(max_size=30)), max_size=8),
        st.sampled_from([".eds", ".dcf", ".txt"]),
    )
    settings(CASES, max_examples=cases)(given(*mutations)(_eds_file))()


def _eds_file(deleted: list[int], replaced: list[tuple[int, str]], suffix: str) -> None:
    lines = list(EDS_LINES)
    for i, text in replaced:
        key = lines[i].split("=", 1)[0] if "=" in lines[i] else ""
        lines[i] = f"{key}={text}" if key else text
    lines = [line for i, line in enumerate(lines) if i not in set(deleted)]
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / f"drive{suffix}"
        path.write_bytes("\n".join(lines).encode("utf-8", "replace"))
        try:
            load_od(path, 1)
        except ConfigError as exc:
            assert str(path) in str(exc)


KNOWN_LENGTHS = {0x000: 2, 0x201: 6, 0x301: 6, 0x401: 6, 0x501: 5, 0x601: 8, 0x602: 8}
frames = st.one_of(
    st.tuples(
        st.integers(0, 0x7FF).filter(lambda i: i not in KNOWN_LENGTHS and i != 0x80), st.binary(max_size=8)
    ),
    st.sampled_from(sorted(KNOWN_LENGTHS)).flatmap(
        lambda i: st.tuples(
            st.just(i), st.binary(max_size=8).filter(lambda b, i=i: len(b) != KNOWN_LENGTHS[i])
        )
    ),
)


@pytest.fixture(scope="module")
def bench() -> Any:
    b = LockstepBench("dc-servo")
    drive = Cia402Axis("drive", b.host, 1, mode="voltage", sync_rpdo=False)
    drive.setup()  # OPERATIONAL, never enabled
    rogue = b.hub.bus(queue=False, channel="rogue")
    yield b, drive, rogue
    rogue.shutdown()
    drive.close()
    b.close()


@TIERS
def test_can_frames_with_wrong_lengths_and_unknown_ids(bench: Any, cases: int) -> None:
    b, drive, rogue = bench

    @settings(CASES, max_examples=cases)
    @given(st.lists(frames, min_size=1, max_size=10))
    def send(batch: list[tuple[int, bytes]]) -> None:
        _send_frames(b, drive, rogue, batch)

    send()


def _send_frames(b: Any, drive: Any, rogue: Any, batch: list[tuple[int, bytes]]) -> None:
    emulated = b.devices[0]
    for can_id, data in batch:
        rogue.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))
        b.sync()
        try:
            drive.feedback()
        except CommunicationError:
            pass
    assert emulated.sm.state is not PowerState.OPERATION_ENABLED  # no frame enabled the drive
    assert emulated.axis.command == 0.0  # and none reached the motor


class _Answer:
    def __init__(self, error: bool, code: Any, registers: Any) -> None:
        self._error, self.exception_code, self.registers = error, code, registers

    def isError(self) -> bool:
        return self._error


answers = st.one_of(
    st.none(),
    st.builds(
        _Answer,
        st.booleans(),
        st.one_of(st.integers(-5, 300), st.none()),
        st.one_of(
            st.none(), st.lists(st.one_of(st.integers(-(2**20), 2**20), st.text(max_size=3)), max_size=3)
        ),
    ),
)


@TIERS
def test_modbus_answers(cases: int) -> None:
    roles = st.sampled_from(["actual_speed", "current", "status_word", "fault_code"])
    settings(CASES, max_examples=cases)(given(answers, roles)(_modbus_answer))()


def _modbus_answer(answer: Any, role: str) -> None:
    inverter = ModbusInverterAxis("inverter", "abb-drives-profile", host="127.0.0.1", port=1)

    class Client:
        def read_holding_registers(self, *args: Any, **kwargs: Any) -> Any:
            return answer

        def write_register(self, *args: Any, **kwargs: Any) -> Any:
            return answer

        def close(self) -> None:
            pass

    inverter.client = Client()
    calls = (
        lambda: inverter.read(role),
        lambda: inverter.write("speed_reference", 10.0),
        lambda: inverter.feedback().velocity,
    )
    for call in calls:
        try:
            value = call()
            assert value is None or math.isfinite(value)
        except ModbusExceptionResponse as exc:
            assert "register" in str(exc) and "exception code" in str(exc)
        except CommunicationError as exc:
            assert "register" in str(exc)
    inverter.close()
