"""``rig drive sdo read/write OBJECT``: how an object is written on the command line."""

from __future__ import annotations

import pytest

from drivers.errors import ConfigError
from drivers.maps import CIA402_EDS
from drivers.maps.od import load_od
from rig.commission.drive import parse_object


@pytest.fixture(scope="module")
def od():  # type: ignore[no-untyped-def]
    return load_od(CIA402_EDS, 1)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("0x6060", (0x6060, 0)),
        ("6060", (0x6060, 0)),
        ("0x1018:1", (0x1018, 1)),
        ("0x1018:01", (0x1018, 1)),  # as rig drive itself prints it: was refused
        ("0x1A00:10", (0x1A00, 16)),  # hexadecimal, as an EDS's 1A00sub10
        ("1A00sub10", (0x1A00, 16)),
        ("0x1A00:0x10", (0x1A00, 16)),
        ("Modes of operation", (0x6060, 0)),
    ],
)
def test_an_object_is_read_as_an_eds_and_rig_drive_write_it(od, text: str, key: tuple[int, int]) -> None:  # type: ignore[no-untyped-def]
    """Index and sub-index in hexadecimal, with or without 0x: what ``rig drive`` prints
    (``0x1018:01``) is taken back as it is."""
    assert parse_object(text, od) == key


@pytest.mark.parametrize("text", ["0x1018:100", "0x10000", "no such object"])
def test_an_object_out_of_range_or_unknown_is_named(od, text: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ConfigError, match=repr(text)):
        parse_object(text, od)
