"""Shared fixtures: no test reads the user's CAN configuration or environment by surprise."""

from __future__ import annotations

import pathlib
import sys

import pytest


@pytest.fixture(autouse=True)
def _clean_environ(monkeypatch: pytest.MonkeyPatch, tmp_path: pytest.TempPathFactory) -> None:
    monkeypatch.chdir(tmp_path)  # run directories ("runs/") land in the test's own tmp dir
    for name in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(name, raising=False)


#: the hardware options, spelt as rig's own (``rig drive --interface ... --node ... --eds ...``):
#: (names, the old spelling kept for one release or None, argparse keywords)
HARDWARE_OPTIONS: tuple[tuple[str, str | None, dict[str, object]], ...] = (
    (
        "--interface",
        "--can-interface",
        {"help": "python-can interface of a real bus (enables 'hardware' tests)"},
    ),
    ("--channel", "--can-channel", {"help": "python-can channel of the real bus, e.g. can0"}),
    (
        "--node",
        "--drive-node",
        {"type": int, "default": 1, "help": "node id of the CiA 402 drive on the bus"},
    ),
    (
        "--bitrate",
        None,
        {"type": int, "default": 0, "help": "bit rate of the real bus [bit/s] (0: the interface's)"},
    ),
    (
        "--eds",
        None,
        {"help": "the drive's EDS/DCF, relative to where pytest is run (default: the toolkit's)"},
    ),
    ("--host", "--can-host", {"default": "127.0.0.1", "help": "socketcand host"}),
    ("--port", "--can-port", {"type": int, "default": 29536, "help": "socketcand port"}),
    (
        "--units",
        "--axis-units",
        {"action": "append", "metavar": "NAME=VALUE", "help": "a factor the drive lacks ([axis.units])"},
    ),
)


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("drive-rig hardware")
    for name, old, kw in HARDWARE_OPTIONS:
        dest = name.lstrip("-")
        group.addoption(name, *([old] if old else []), dest=dest, **kw)  # type: ignore[arg-type]


def pytest_configure(config: pytest.Config) -> None:
    """The hardware options as given where pytest was run: an old spelling says its new one (once,
    not again on each xdist worker); a relative --eds is taken from the folder pytest was started in
    (each test runs in a tmp folder of its own, ``_clean_environ``); and with a bus given, the
    session runs in this one process whatever ``-n`` says: a drive answers one SDO client at a
    time, and xdist workers would be two (pytest-xdist's ``xdist_group`` cannot keep them to one
    worker under pytest 9.2: pytest-xdist issue 1386). xdist's own ``pytest_configure`` runs last
    and starts no workers then."""
    if config.getoption("interface"):
        config.option.dist, config.option.tx = "no", []
    if not hasattr(config, "workerinput"):
        args = [str(a).split("=")[0] for a in config.invocation_params.args]
        for name, old, _ in HARDWARE_OPTIONS:
            if old in args:
                print(f"pytest: {old} is deprecated: use {name} (as rig drive spells it)", file=sys.stderr)
    eds = config.getoption("eds")
    if eds and not pathlib.Path(eds).is_absolute():
        config.option.eds = str(config.invocation_params.dir / eds)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's, which reads the groups
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    _one_worker_per_module_fixture(items)
    hardware = bool(config.getoption("interface"))
    vcan = "vcan" in (config.getoption("markexpr") or "")
    skip_hw = pytest.mark.skip(reason="needs --interface/--channel (a real bus)")
    skip_vcan = pytest.mark.skip(
        reason="the vcan tier runs only with -m vcan (see docs/testing.md, Testing with virtual CAN)"
    )
    for tier in ("interop", "export", "browser"):  # these tiers only when asked for
        if tier not in (config.getoption("markexpr") or ""):
            chosen = [item for item in items if tier not in item.keywords]
            if len(chosen) != len(items):
                config.hook.pytest_deselected(items=[item for item in items if tier in item.keywords])
                items[:] = chosen
    for item in items:
        if "hardware" in item.keywords and not hardware:
            item.add_marker(skip_hw)
        if "vcan" in item.keywords and not vcan:
            item.add_marker(skip_vcan)


def _one_worker_per_module_fixture(items: list[pytest.Item]) -> None:
    """pytest-xdist (``--dist loadgroup``): the tests that share a module-scoped fixture (a whole
    study, the fault suite's table) go to one worker, which makes it once; every other test goes
    to whichever worker is free."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        defs = info.name2fixturedefs.values() if info is not None else ()
        if any(d[-1].scope == "module" for d in defs if d):
            item.add_marker(pytest.mark.xdist_group(item.module.__name__ if item.module else item.nodeid))


@pytest.hookimpl(trylast=True, specname="pytest_collection_modifyitems")  # after xdist's, which names groups
def pytest_collection_modifyitems_names_groups(config: pytest.Config, items: list[pytest.Item]) -> None:
    """On an xdist worker under ``--dist loadgroup``: each grouped test's id ends in ``@GROUP``,
    which is what the controller schedules by. pytest-xdist 3.8 writes that id to
    ``item._nodeid``, which pytest 9.2 no longer reads (its id is ``item._id``: pytest-xdist
    issue 1386), so every test was a group of its own: a module's fixture was made again on
    each worker, and again each time another module's test came between two of its tests (the
    drives study 2 times, 80 s each at load 15). Where xdist's own suffix took, nothing is done."""
    if not (hasattr(config, "workerinput") and config.getvalue("loadgroup")):
        return
    from _pytest.nodeid import NodeId  # pytest's own id type (pytest >= 9.2)

    for item in items:
        names = sorted({str(m.args[0]) for m in item.iter_markers("xdist_group") if m.args})
        if names and "@" not in item.nodeid and hasattr(item, "_id"):
            item._id = NodeId.parse(f"{item.nodeid}@{'_'.join(names)}")


@pytest.fixture(autouse=True)
def _no_run_plots(monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs in this process write no plot.png (matplotlib is in the test extras; a figure per
    run would add seconds to every test that runs a rig); the recorder's plot test turns it on."""
    from rig.host.recorder import Recorder

    monkeypatch.setattr(Recorder, "PLOT", False)
