"""Fixtures of the rig tests."""

from __future__ import annotations

import contextlib
import io
import json
import pathlib
from collections.abc import Callable, Iterator

import pytest

from tests.patching import forget, stand_in


@pytest.fixture
def opened(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """What a run opened of the bus and the emulated world: each is refused wherever a module
    bound it (``tests.patching``; a run given a bad input must not get there), so the list is
    empty unless a check came too late."""
    seen: list[str] = []

    def refuse(what: str) -> Callable[..., None]:
        def opener(*args: object, **kwargs: object) -> None:
            seen.append(what)
            raise AssertionError(f"{what} opened before the input was checked")

        return opener

    stand_ins = [
        stand_in(monkeypatch, "drivers.bus.open_bus", refuse("bus")),
        stand_in(monkeypatch, "rig.host.emulation.Emulation", refuse("emulation")),
    ]
    yield seen
    forget(stand_ins)


@pytest.fixture(scope="session")
def identified(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """The run directory of ``rig identify --emulate dc-servo --excitation multisine --f-min 10``,
    made once per test process for the tests that read it (rig tune's, the armature pole's): the
    emulated servo with its 0.1 ms armature pole and the synchronous RPDO's period of delay,
    10 Hz to 500 Hz, 41 periods (36 averages); in a temporary folder, not the checkout."""
    from rig.cli import main

    buf = io.StringIO()
    argv = ["identify", "--emulate", "dc-servo", "--excitation", "multisine", "--f-min", "10", "--json"]
    with contextlib.chdir(tmp_path_factory.mktemp("identified")):  # runs/ there, not in the checkout
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
            assert main(argv) == 0
        return pathlib.Path(json.loads(buf.getvalue())["run_dir"]).resolve()


@pytest.fixture
def client():  # type: ignore[no-untyped-def]
    """A Dask LocalCluster in this process (threads: quick to start) and its client, for sweeps."""
    from dask.distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address="127.0.0.1:0"
        ) as cluster,
        Client(cluster) as c,
    ):
        yield c
