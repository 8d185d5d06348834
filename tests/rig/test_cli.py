"""The ``rig`` command line, called through ``main(argv)``."""

from __future__ import annotations

import json
import pathlib
from collections.abc import Iterator
from typing import Any

import pytest

import drivers.bus
import rig.host.emulation
import rig.host.transport
from rig.cli import main
from tests.patching import forget, stand_in


def test_design_dtsm_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(
        [
            "design",
            "dtsm",
            "--a-m",
            "16",
            "--b-m",
            "680",
            "--period",
            "0.4e-3",
            "--lam",
            "-15",
            "--error-space",
            "--json",
        ]
    )
    out = capsys.readouterr()
    assert rc == 0 and out.err == ""
    doc = json.loads(out.out)
    assert set(doc) == {
        "A_delta",
        "b_delta",
        "lambda_delta",
        "k_delta",
        "c_delta",
        "c_delta_A_delta",
        "a_m",  # the model with the design, for [controller] design = "FILE"
        "b_m",
        "lam",
        "dt",
        "input",
    }
    assert [round(v, 4) for v in doc["A_delta"][1]] == [0.0, -15.9489]
    assert round(doc["b_delta"][1], 6) == -677.828635
    assert [round(c, 4) for c in doc["c_delta"]] == [-0.0221, -0.0015]
    assert [round(c, 4) for c in doc["c_delta_A_delta"]] == [0.0, 0.0015]
    assert isinstance(doc["lambda_delta"], float)


def test_design_dtsm_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", "dtsm", "--a-m", "16", "--b-m", "680", "--period", "1e-3", "--lam", "-15"]) == 0
    assert "c_delta A_delta" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--period", "0"], "--period"),
        (["--period", "-1e-3"], "--period"),
        (["--period", "abc"], "--period"),
        (["--a-m", "nan"], "--a-m"),
        (["--lam", "3"], "--lam"),
        (["--b-m", "0"], "not controllable"),
    ],
)
def test_design_dtsm_bad_arguments_one_line_exit_2(
    argv: list[str], needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    base = {"--a-m": "16", "--b-m": "680", "--period": "1e-3", "--lam": "-15"}
    base.update(dict(zip(argv[::2], argv[1::2])))
    args = ["design", "dtsm", *[x for kv in base.items() for x in kv], "--json"]
    assert main(args) == 2
    out = capsys.readouterr()
    assert out.out == ""
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0]


def test_unknown_command_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fly"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_bench_json_contract(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from rig import bench
    from rig.bench.micro import bench_controllers

    monkeypatch.setitem(bench.BENCHMARKS, "controllers", lambda: bench_controllers(n=200, repeats=1))
    assert main(["bench", "controllers", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert isinstance(doc, list) and doc
    for fig in doc:
        assert set(fig) == {"name", "value", "unit"} and fig["unit"] == "us/step" and fig["value"] > 0


def test_a_run_stopped_at_its_start_says_its_chattering_was_not_measured(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two cycles, then a NaN from the law: a run that stopped has no performance figures (NaN,
    never 0: issue 35); the summary says so in words, not 'RMS increment nan V' or 'nan rad', and
    gives the error before the stop apart."""
    monkeypatch.chdir(tmp_path)
    example = str(pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml")
    assert main(["run", "--config", example, "--emulate", "--fault", "law_nan_at=0.001"]) == 3
    out = capsys.readouterr().out
    assert "chattering      not measured: the run stopped" in out
    assert "increment nan" not in out and "nan rad" not in out
    assert "rms error       - (the run stopped; " in out and "sign law        not measured" in out
    summary = json.loads(
        (pathlib.Path(out.split("run directory")[1].split()[0]) / "summary.json").read_text()
    )
    assert summary["status"] == "stopped" and summary["cut_short"]["rms_error"] >= 0.0
    assert all(summary[k] is None for k in ("rms_error", "max_error", "chattering_count", "sign_law_share"))


def test_bench_physics_json_contract(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from rig import bench
    from rig.bench.micro import bench_physics

    monkeypatch.setitem(bench.BENCHMARKS, "physics", lambda: bench_physics(n=400, cycles=20, repeats=1))
    assert main(["bench", "physics", "--json"]) == 0
    figures = {f["name"]: f for f in json.loads(capsys.readouterr().out)}
    assert {"dc-servo_physics_steps_per_s", "dc-servo_lockstep_cycles_per_s"} <= set(figures)
    # the contract, not the figures (a benchmark's figures depend on the machine's load)
    assert all(isinstance(f["value"], (int, float)) and f["value"] >= 0 for f in figures.values())


def test_scan_lists_the_emulated_nodes(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scan", "--emulate", "dc-servo", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["node_id"], r["profile"], r["nmt_state"]) for r in rows] == [
        (1, "CiA 402 drive", "PRE-OPERATIONAL"),
        (2, "CiA 406 encoder", "PRE-OPERATIONAL"),
    ]
    assert rows[0]["product_name"] == "drive-rig emulated servo drive"
    assert all(r["errors"] == [] for r in rows)


@pytest.mark.parametrize(
    ("preset", "products"),
    [
        ("im-drive", {1: ("0x00010192", "drive-rig emulated induction-motor inverter (FOC)")}),
        ("grid-converter", {1: ("0x00020192", "drive-rig emulated grid converter (dq current control)")}),
        ("dyno", {3: ("0x00020192", "drive-rig emulated load machine (dyno)")}),
    ],
)
def test_scan_says_what_each_emulated_drive_is(
    preset: str, products: dict[int, tuple[str, str]], capsys: pytest.CaptureFixture[str]
) -> None:
    """0x1008 names the device, not the EDS's servo drive; an inverter's 0x1000 says
    frequency converter (CiA 402 additional information 0x01)."""
    assert main(["scan", "--emulate", preset, "--json"]) == 0
    rows = {r["node_id"]: r for r in json.loads(capsys.readouterr().out)}
    for node, (device_type, name) in products.items():
        assert (rows[node]["device_type"], rows[node]["product_name"]) == (device_type, name)
        assert rows[node]["profile"] == "CiA 402 drive"


def _node_without_0x1008(tmp_path: pathlib.Path, bench: Any, node_id: int, device_type: int) -> Any:
    """An emulated node on ``bench`` from the toolkit's encoder EDS without 0x1008, whose 0x1000
    is ``device_type``: the SDO server aborts an upload of 0x1008 (0x06020000)."""
    from drivers.maps import CIA406_EDS
    from plant_emulator.canopen_node import EmulatedNode

    sections = pathlib.Path(CIA406_EDS).read_text().split("\n[")
    eds = tmp_path / "no_name.eds"
    eds.write_text("\n[".join(part for part in sections if not part.startswith("1008]")))
    node = EmulatedNode(node_id, str(eds), bench.device_network)
    node.write(0x1000, 0, device_type)
    node.boot()
    return node


def test_scan_a_node_without_a_name_or_a_profile(tmp_path: pathlib.Path) -> None:
    """A missing 0x1008 is None (JSON) and '-' (table), said once in errors; 0x1000 and 0x1018:1
    are still read. Device type 0 is "none given", an unknown profile number says so."""
    from plant_emulator.lockstep import LockstepBench
    from rig.cli.scan import table
    from rig.commission.scan import scan

    bench = LockstepBench("grid-converter")
    try:
        _node_without_0x1008(tmp_path, bench, 7, 0)
        _node_without_0x1008(tmp_path, bench, 9, 0x0001_0999)
        rows = {r["node_id"]: r for r in scan(bench.host, listen=lambda: None)}
    finally:
        bench.close()
    assert sorted(rows) == [1, 7, 9]
    abort = "0x1008:00: SDO abort: Code 0x06020000, Object does not exist"
    assert rows[7] == {
        "node_id": 7,
        "nmt_state": "unknown",  # no heartbeat heard: found by its SDO answer
        "device_type": "0x00000000",
        "profile": "none given",
        "vendor_id": "0x00000DB1",
        "vendor_name": "drive-rig",  # CiA's vendor-ID list (drivers.maps.vendors)
        "product_name": None,
        "errors": [abort],
    }
    assert (rows[9]["device_type"], rows[9]["profile"]) == ("0x00010999", "2457 (unknown profile)")
    lines = table(list(rows.values()))
    assert lines[2] == "   7  unknown    0x00000000   none given              0x00000DB1  drive-rig    -"
    assert lines[3] == "   9  unknown    0x00010999   2457 (unknown profile)  0x00000DB1  drive-rig    -"
    assert lines[4:] == [f"node 7: {abort}", f"node 9: {abort}"]


def test_scan_a_node_heard_but_not_answering_is_asked_once() -> None:
    """A STOPPED node (no SDO in that state, CiA 301) found by its heartbeat: one error, not three
    timeouts, and its state from the heartbeat."""
    from plant_emulator.lockstep import LockstepBench
    from rig.commission.scan import scan

    bench = LockstepBench("grid-converter")

    def listen() -> None:  # 0.2 s of emulated time: heartbeats every 0.1 s
        for k in range(1, round(0.2 / bench.period) + 1):
            for d in bench.devices:
                d.tick(k * bench.period)

    try:
        bench.host.nmt.send_command(0x02)  # NMT stop, all nodes
        (row,) = scan(bench.host, listen=listen)
    finally:
        bench.close()
    assert row["nmt_state"] == "STOPPED" and row["device_type"] is None and row["product_name"] is None
    assert row["errors"] == ["0x1000:00: no SDO answer within 0.1 s"]


def test_run_json_summary_contract(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    cfg = tmp_path / "c.toml"
    cfg.write_text(example.read_text().replace('output = "runs"', f'output = "{tmp_path}"'))
    assert main(["run", "--config", str(cfg), "--emulate", "--duration", "0.2", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    keys = {"cycles", "rms_error", "max_error", "chattering_count", "overruns", "safe_stop_reason", "run_dir"}
    assert keys <= set(summary) and summary["cycles"] == 500 and summary["safe_stop_reason"] is None
    assert main(["run", "--config", str(tmp_path / "missing.toml"), "--emulate"]) == 2
    assert "missing.toml" in capsys.readouterr().err
    assert set(summary["axes"]) == {"motor"} and summary["axes"]["motor"]["max_abs_velocity"] > 0


def test_verbose_after_the_subcommand_and_quiet_libraries() -> None:
    """``-v`` is accepted after any subcommand (also a nested one); without it pymodbus's own
    error lines (raw frames) stay out: the Modbus driver says what failed in its words."""
    import logging

    from rig.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["run", "--config", "x.toml", "-v"]).verbose is True
    assert parser.parse_args(["-v", "run", "--config", "x.toml"]).verbose is True
    assert parser.parse_args(["design", "dtsm", "-v", "--lam", "-1"]).verbose is True
    assert parser.parse_args(["run", "--config", "x.toml"]).verbose is False
    assert main(["design", "dtsm", "--a-m", "16", "--b-m", "680", "--period", "4e-4", "--lam", "-15"]) == 0
    assert logging.getLogger("pymodbus").level == logging.CRITICAL


def test_a_reader_that_leaves_is_no_traceback() -> None:
    """``rig design dtsm ... | true`` (the reader gone before rig writes): exit 141 and nothing
    on stderr."""
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "rig.cli", "design", "dtsm", "--a-m", "16", "--b-m", "680"]
    shell = subprocess.run(
        f'{" ".join(cmd)} --period 4e-4 --lam -15 | true; echo " ${{PIPESTATUS[0]}}"',
        shell=True,
        executable="/bin/bash",
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert shell.stderr == "" and shell.stdout.endswith(" 141\n"), (shell.stdout, shell.stderr)


def test_every_subcommand_s_help_ends_with_an_example_that_parses(capsys: pytest.CaptureFixture[str]) -> None:
    from rig.cli import EXAMPLES, SUBCOMMANDS, build_parser

    parser = build_parser()
    names = set(EXAMPLES)
    assert len(names) == len(SUBCOMMANDS)
    for name, example in EXAMPLES.items():
        with pytest.raises(SystemExit) as exited:
            main([name, "--help"])
        assert exited.value.code == 0, name  # the help, not a usage error
        assert f"Example: {example.split()[0]}" in capsys.readouterr().out
        argv = example.split("(")[0].split()
        assert argv[0] == "rig" and argv[1] == name
        parser.parse_args(argv[1:])  # the example is a valid command line


@pytest.fixture
def nothing_opens(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """Each way a command opens a bus, serves, builds an emulated world or runs an experiment,
    refused wherever the command finds it (the defining module and each module that bound the
    name at import: rig.host.transport's open_bus, rig.host.emulation's LockstepBench): a bad
    argument must be found before any of them."""
    seen: list[str] = []

    def refuse(what: str) -> object:
        def opener(*args: object, **kwargs: object) -> None:
            seen.append(what)
            raise AssertionError(f"{what} before the arguments were checked")

        return opener

    stand_ins = [stand_in(monkeypatch, target, refuse(target)) for target in OPENERS]
    yield seen
    forget(stand_ins)


#: what opens a bus, serves, builds an emulated world or runs an experiment
OPENERS = (
    "drivers.bus.open_bus",
    "rig.emulator.serve.run_emulator",
    "rig.emulator.serve.run_modbus_emulator",
    "plant_emulator.lockstep.LockstepBench",
    "rig.identify.experiment.run_experiment",
    "rig.papers.dismc.run_dismc",
)


def test_nothing_opens_sees_each_opener_where_the_commands_find_it(
    monkeypatch: pytest.MonkeyPatch, nothing_opens: list[str]
) -> None:
    """The fixture's stand-ins are what the modules that bound the openers at import call: the
    session's bus and emulated world included (patching the defining modules alone left those
    calling the real ones, unseen). Both modules were imported with this one, before the patch."""
    for module, name in ((rig.host.transport, "open_bus"), (rig.host.emulation, "LockstepBench")):
        with pytest.raises(AssertionError, match="before the arguments were checked"):
            getattr(module, name)()
    assert nothing_opens == ["drivers.bus.open_bus", "plant_emulator.lockstep.LockstepBench"]
    assert rig.host.transport.open_bus is drivers.bus.open_bus


def _one_line(capsys: pytest.CaptureFixture[str], needles: tuple[str, ...]) -> None:
    out = capsys.readouterr()
    lines = out.err.splitlines()
    assert out.out == "" and len(lines) == 1, out.err
    assert all(n in lines[0] for n in needles), lines[0]
    assert not lines[0].startswith("rig: rig "), lines[0]  # the subcommand named once


HOSTILE_ARGUMENTS = [
    ("scan --interface nosuch --channel x", ("--interface 'nosuch'", "known: ", "socketcand")),
    ("scan --interface socketcand --port 99999", ("--port", "99999")),
    ("scan --emulate dc-servo --listen 0", ("--listen", "got 0")),
    ("scan --emulate dc-servo --listen -1", ("--listen", "got -1")),
    ("scan --emulate dc-servo --listen 1e9", ("--listen", "1e+09")),
    ("scan --emulate dc-servo --sdo-timeout 0", ("--sdo-timeout", "got 0")),
    ("scan --emulate dc-servo --sdo-timeout 100", ("--sdo-timeout", "got 100")),
    ("bench loop --load 2", ("--load", "only rig bench stops")),
    ("bench stops --period 0", ("--period", "got 0")),
    ("bench stops --load -1", ("--load", "got -1")),
    ("emulate --preset dc-servo --port 99999", ("--port", "99999")),
    ("emulate --preset dc-servo --port -1", ("--port", "-1")),
    ("emulate --preset dc-servo --bitrate 0", ("--bitrate", "0 bit/s", "1 .. 1000000")),
    ("emulate --preset dc-servo --bitrate 2000000", ("--bitrate", "2000000 bit/s")),
    ("emulate --preset dc-servo --bitrate fast", ("--bitrate", "'fast'")),
    ("emulate --modbus-map abb-drives-profile --port 0", ("--port", "got 0")),
    ("emulate --interface nosuch --channel x --preset dc-servo", ("--interface 'nosuch'", "known: ")),
    ("emulate --preset dc-servo --param a_m=inf", ("--param", "a_m", "inf")),
    ("emulate --preset dc-servo --period 1e-12", ("--preset dc-servo --period 1e-12", "1e-05 .. 10 s")),
    ("emulate --device epos4 --period 20", ("--period 20", "1e-05 .. 10 s")),
    ("emulate --preset grid-converter --param f_line=inf", ("--param", "f_line", "inf")),
    ("emulate --preset grid-converter --param f_line=1e9", ("--param", "ratio/f_line")),
    ("emulate --device epos4 --param a_m=-1", ("--device epos4 --param", "a_m", "-1")),
    ("emulate --profile /", ("/: a directory", "device profile")),
    ("emulate --profile /nonexistent.toml", ("/nonexistent.toml: no such device profile",)),
    ("run --config examples/dc_servo_position.toml --emulate --duraton 1", ("rig run: ", "--duraton 1")),
    ("run --config examples/dc_servo_position.toml --emulate --duration 0", ("--duration", "got 0")),
    ("run --config examples/dc_servo_position_rt.toml --duration -1", ("--duration", "got -1")),
    ("design dtsm --a-m 16 --b-m 680 --lam -15 --dtt 1e-3", ("rig design dtsm: ", "--dtt 1e-3")),
    ("emulate --preset dc-serv", ("--preset dc-serv: unknown preset", "known: dc-servo")),
    ("emulate --device epos5", ("--device epos5", "unknown device profile", "epos4")),
    ("emulate --preset dc-servo --node 126", ("--node 126", "1..125", "N+2")),
    ("drive --interface nosuch --channel x status", ("--interface 'nosuch'", "known: ")),
    ("drive --interface socketcand --port 70000 status", ("--port", "70000")),
    ("drive --emulate epos4 --node 128 status", ("--node", "128")),
    ("drive --emulate epos4 --units counts_per_rev=-5 status", ("--units", "counts_per_rev = -5")),
    ("drive --emulate epos4 sdo write 0x6060 nan", ("sdo write", "'nan'")),
    ("drive --emulate epos4 sdo write 0x6060 1e400", ("sdo write", "'1e400'")),
    ("drive --emulate epos4 jog 10 --for 1 --limit 0", ("--limit", "got 0")),
    ("drive --emulate epos4 move 1 --limit -5", ("--limit", "got -5")),
    ("drive --emulate epos4 sdo read 0x1018:300", ("'0x1018:300'", "sub-index 0..255")),
    ("drive --emulate epos4 sdo read nosuchname", ("'nosuchname'", "EDS")),
    ("drive --interface socketcan --channel can0 sdo read 0x10000", ("'0x10000'", "index 0..0xFFFF")),
    ("drive --interface socketcan --channel can0 --eds /nonexistent.eds status", ("/nonexistent.eds",)),
    ("identify --emulate dc-servo --duration -1", ("--duration", "got -1")),
    ("identify --emulate dc-servo --duration 1e9", ("--duration", "1e+09")),
    ("identify --emulate dc-servo --clock 0", ("--clock", "got 0")),
    ("identify --emulate dc-servo --clock 1e-5", ("--clock", "1e-05", "period")),
    ("identify --emulate dc-servo --seed -1", ("--seed", "got -1")),
    ("identify --emulate dc-servo --param plant.a_m=-5", ("--emulate dc-servo", "a_m", "-5")),
    ("identify --emulate dc-servo --param plant.period=inf", ("--emulate dc-servo", "period", "inf")),
    (
        "identify --emulate dc-servo --plot /dev/null/figs",
        ("--plot", "cannot make the folder", "Not a directory"),
    ),
    ("reproduce dq-current --plot /dev/null", ("--plot /dev/null", "cannot make the folder")),
    ("reproduce drives --plot x.png", ("--plot x.png", "give a folder", "not a file name")),
    ("reproduce dismc --param Ts=0", ("--param", "Ts", "0.0")),
    ("reproduce dismc --param x0=inf,0", ("--param", "x0", "inf")),
]


@pytest.mark.timeout(30)
@pytest.mark.parametrize(("argv", "needles"), HOSTILE_ARGUMENTS, ids=[a for a, _ in HOSTILE_ARGUMENTS])
def test_a_hostile_argument_is_one_line_exit_2_before_anything_opens(
    argv: str,
    needles: tuple[str, ...],
    tmp_path: pathlib.Path,
    capsys: pytest.CaptureFixture[str],
    nothing_opens: list[str],
) -> None:
    (tmp_path / "examples").symlink_to(
        pathlib.Path(__file__).resolve().parents[2] / "examples"
    )  # as in a clone
    assert main(argv.split()) == 2
    _one_line(capsys, needles)
    assert not nothing_opens


#: mistakes only the device or the system tells: the object's type (before any write), an address
#: that cannot be served on, a serial device that is not there (nothing announced as served, and
#: no warning of a bus left open)
MET_LATE = [
    ("drive --emulate epos4 sdo write 0x6060 99999999999", ("'99999999999'", "0x6060:00")),
    ("drive --emulate epos4 sdo write 0x1008 1", ("0x1008:00", "is const in the EDS: nothing was sent")),
    ("emulate --preset dc-servo --host 999.1.1.1", ("--host 999.1.1.1", "cannot listen")),
    ("emulate --modbus-map abb-drives-profile --modbus-serial /nonexistent", ("/nonexistent", "no such")),
]


@pytest.mark.timeout(30)
@pytest.mark.parametrize(("argv", "needles"), MET_LATE, ids=[a for a, _ in MET_LATE])
def test_a_mistake_the_device_or_the_system_tells_is_one_line_exit_2(
    argv: str, needles: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv.split()) == 2
    _one_line(capsys, needles)


@pytest.mark.timeout(30)
@pytest.mark.parametrize(
    "argv",
    [
        "emulate --preset dc-servo --interface socketcan --channel rig-missing0",
        "drive --interface socketcan --channel rig-missing0 status",
        "scan --interface socketcan --channel rig-missing0",
    ],
)
def test_a_bus_that_cannot_be_opened_is_one_line_exit_1_in_every_command(
    argv: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """No such CAN channel (or no SocketCAN at all): a connection failure, exit 1, whichever
    command opens the bus (``rig emulate`` said 2, as for a mistaken argument)."""
    assert main(argv.split()) == 1
    _one_line(capsys, ("rig-missing0", "cannot open"))


def test_an_absolute_reference_away_from_the_shaft_is_refused_before_a_command(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``origin = "zero"`` with a reference that does not start where the shaft stands (here a
    constant 5 rad, the shaft at 0): the position servo would drive it there at full force. The
    run stops before its first command (exit 3), saying where the reference starts and the shaft
    stands; no voltage was sent."""
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    text = example.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    head, _, _ = text.partition("[reference]")
    cfg = tmp_path / "c.toml"
    cfg.write_text(head + '[reference]\nkind = "constant"\nvalue = 5.0\norigin = "zero"\n')
    assert main(["run", "--config", str(cfg), "--emulate", "--json"]) == 3
    summary = json.loads(capsys.readouterr().out)
    reason = summary["safe_stop_reason"]
    assert "the reference starts at 5 rad" in reason and "measured position 0 rad" in reason, reason
    assert summary["stop_confirmed"] is True and summary["cycles"] == 0
    assert summary["axes"]["motor"]["max_abs_command"] == 0.0


def test_an_axis_on_a_node_that_is_no_drive_is_one_line_and_no_write(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    """A copied example with the wrong ``node_id`` (2: the dc-servo preset's CiA 406 encoder):
    one line naming the axis and the node, exit 2, and no controlword written to that node on
    the way out (before, a warning that "disabling on close failed" came with it)."""
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    text = example.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    cfg = tmp_path / "c.toml"
    cfg.write_text(text.replace("node_id = 1", "node_id = 2"))
    assert main(["run", "--config", str(cfg), "--emulate"]) == 2
    _one_line(capsys, ("axis 'motor'", "node 2 is not a CiA 402 drive", "profile 406"))
    assert not [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]


def test_a_profile_that_disagrees_with_its_eds_is_refused_before_serving(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], nothing_opens: list[str]
) -> None:
    """README "A twin of your own drive": a profile whose ``[modes] supported`` disagrees with
    the EDS's 0x6502 is one line naming the file and the key, exit 2, before the socketcand
    port is bound (before, it was found once serving: the port was taken and "rig emulate:
    stopped" printed for an emulator that never ran)."""
    import shutil

    devices = pathlib.Path(__file__).resolve().parents[2] / "plant_emulator" / "devices"
    shutil.copy(devices / "epos4.eds", tmp_path / "mydrive.eds")
    profile = tmp_path / "mydrive.toml"
    profile.write_text('[device]\neds = "mydrive.eds"\n\n[modes]\nsupported = ["pp", "pv"]\n')
    assert main(["emulate", "--profile", str(profile), "--eds", str(tmp_path / "mydrive.eds")]) == 2
    _one_line(capsys, ("mydrive.toml", "[modes] supported", "0x6502"))
    assert not nothing_opens


def test_the_run_summary_gives_the_command_s_unit(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The chattering figures and each axis's command peak are in the command's unit, which
    the summary names (before: "(command's unit)" and a bare number)."""
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    cfg = tmp_path / "c.toml"
    cfg.write_text(example.read_text().replace('output = "runs"', f'output = "{tmp_path}"'))
    assert main(["run", "--config", str(cfg), "--emulate", "--duration", "0.2", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["command_unit"] == "V" and summary["command_units"] == {"motor": "V"}
    assert main(["run", "--config", str(cfg), "--emulate", "--duration", "0.2"]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert "command's unit" not in lines["chattering"] and lines["chattering"].endswith(" V")
    assert lines["axis"].startswith("axis motor") and lines["axis"].endswith(" V")


def test_a_move_that_would_leave_the_position_window_is_refused_before_a_command(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The example run a second time against the same emulator starts where the first left the
    shaft (10 rad) and would move to 20 rad, beyond its ``position_max = 12``: here a move of 20
    rad from 0. The run stops before its first command (exit 3), naming where the reference
    goes and the window; before, the motor moved and was stopped at 12 rad."""
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    text = example.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    cfg = tmp_path / "c.toml"
    cfg.write_text(text.replace("distance = 10.0", "distance = 20.0"))
    assert main(["run", "--config", str(cfg), "--emulate", "--json"]) == 3
    summary = json.loads(capsys.readouterr().out)
    reason = summary["safe_stop_reason"]
    assert "the reference goes to 20 rad" in reason and "outside [-1, 12] rad" in reason, reason
    assert summary["stop_confirmed"] is True and summary["cycles"] == 0
    assert summary["axes"]["motor"]["max_abs_command"] == 0.0
