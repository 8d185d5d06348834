"""Fixtures of the rig tests."""

from __future__ import annotations

from collections.abc import Callable

import pytest


@pytest.fixture
def opened(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """What a run opened of the bus and the emulated world: each is refused (a run given a bad
    input must not get there), so the list is empty unless a check came too late."""
    seen: list[str] = []

    def refuse(what: str) -> Callable[..., None]:
        def opener(*args: object, **kwargs: object) -> None:
            seen.append(what)
            raise AssertionError(f"{what} opened before the input was checked")

        return opener

    monkeypatch.setattr("rig.host.session.open_bus", refuse("bus"))
    monkeypatch.setattr("rig.host.session.Emulation", refuse("emulation"))
    return seen
