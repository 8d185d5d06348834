"""The CiA 402 unit codes (0x60A8/0x60A9) and the EDS loader's text encodings."""

from __future__ import annotations

import math
import pathlib

import pytest

from drivers.errors import ConfigError
from drivers.maps import CIA402_EDS
from drivers.maps.od import load_od
from drivers.maps.units import SiUnit


@pytest.mark.parametrize(
    ("code", "text", "per_rev"),
    [
        (0xFF410000, "1e-1 deg", 3600.0),  # a tenth of a degree
        (0x00410000, "deg", 360.0),
        (0x00100000, "rad", 2 * math.pi),
        (0xFD100000, "1e-3 rad", 2000 * math.pi),
        (0x00B50000, "inc", 4096.0),  # increments: the encoder's resolution
        (0x00B40000, "rev", 1.0),
    ],
)
def test_position_units(code: int, text: str, per_rev: float) -> None:
    unit = SiUnit.decode(code)
    assert str(unit) == text
    assert unit.per_revolution(4096) == pytest.approx(per_rev)
    assert unit.encode() == code


@pytest.mark.parametrize(
    ("code", "text", "per_rev_per_s"),
    [
        (0x00B44700, "rev/min", 60.0),  # rpm
        (0xFEB44700, "1e-2 rev/min", 6000.0),
        (0x00B50300, "inc/s", 4096.0),
        (0xFF410300, "1e-1 deg/s", 3600.0),
    ],
)
def test_velocity_units(code: int, text: str, per_rev_per_s: float) -> None:
    unit = SiUnit.decode(code)
    assert str(unit) == text
    assert unit.per_revolution_per_second(4096) == pytest.approx(per_rev_per_s)


@pytest.mark.parametrize(("code", "what"), [(0x00010000, "unit 0x01"), (0x00B45500, "time unit 0x55")])
def test_units_this_toolkit_cannot_convert_are_named(code: int, what: str) -> None:
    with pytest.raises(ValueError, match=f"0x{code:08X}: {what}"):
        SiUnit.decode(code)


def test_an_eds_in_cp1252_loads(tmp_path: pathlib.Path) -> None:
    """A degree sign as Windows-1252 writes it (one byte, 0xB0): not UTF-8, still an EDS."""
    text = (
        pathlib.Path(CIA402_EDS)
        .read_text()
        .replace("ParameterName=Position actual value", "ParameterName=Position actual value (0.1\u00b0)")
    )
    path = tmp_path / "drive.eds"
    path.write_bytes(text.encode("cp1252"))
    od = load_od(path, 1)
    assert od[0x6064].name == "Position actual value (0.1\u00b0)"


def test_an_eds_that_is_no_text_is_named(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "drive.eds"
    path.write_bytes(b"[FileInfo]\n\x81\x8d\n")  # bytes no code page decodes
    with pytest.raises(ConfigError, match=r"drive\.eds: not a valid EDS/DCF"):
        load_od(path, 1)
