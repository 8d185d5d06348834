"""The default run's workers (pytest-xdist, ``--dist loadgroup`` in pyproject.toml): the tests that
share a module-scoped fixture are one group, scheduled to one worker, which makes the fixture once
(``tests/conftest.py``); every other test is a group of its own."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def shared() -> str:
    return "made once"


def _on_a_worker(request: pytest.FixtureRequest) -> None:
    if not hasattr(request.config, "workerinput"):
        pytest.skip("one process (-n 0): no workers to keep together")


def test_the_tests_of_a_module_fixture_are_one_group(shared: str, request: pytest.FixtureRequest) -> None:
    """The controller schedules by what follows the last ``@`` of the id the worker reports
    (pytest-xdist's LoadGroupScheduling); without it the test is a group of its own."""
    _on_a_worker(request)
    name = "test_the_tests_of_a_module_fixture_are_one_group"
    assert request.node.nodeid.endswith(f"::{name}@tests.test_workers")


def test_a_test_without_one_goes_wherever_a_worker_is_free(request: pytest.FixtureRequest) -> None:
    _on_a_worker(request)
    assert "@" not in request.node.nodeid
