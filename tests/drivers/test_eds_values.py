"""The values of an EDS/DCF (DefaultValue, ParameterValue) as CiA 306 writes them: each read, or the
file refused in one line naming the file, the object, the key and the value (``drivers.maps.eds_values``).

canopen's parser leaves a value it cannot read as None without a word; an emulated drive built on
such a file then aborts every read of the object. The fuzz mutates the values of the toolkit's own
EDS and holds every file to: refused in one line naming them, or every numeric value readable.
"""

from __future__ import annotations

import pathlib
import re
import tempfile

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.errors import ConfigError
from drivers.maps import CIA402_EDS
from drivers.maps.eds_values import parse_value, variables
from drivers.maps.od import load_od

U8, U16, U32, I16, I32, REAL32, BOOLEAN = 0x5, 0x6, 0x7, 0x3, 0x4, 0x8, 0x1
EDS_TEXT = pathlib.Path(CIA402_EDS).read_text()
FUZZ = settings(max_examples=150, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))


@pytest.mark.parametrize(
    ("text", "data_type", "value"),
    [
        ("$NODEID+0x180", U32, 0x180 + 5),
        ("0x180+$NODEID", U32, 0x180 + 5),
        ("$NODEID", U8, 5),  # canopen leaves this one None
        ("$nodeid + 0x200", U32, 0x205),
        ("010", U16, 8),  # CiA 306: a leading 0 is octal (canopen: None)
        ("0xFFFF", I16, -1),  # a signed type in hexadecimal: its two's complement (canopen: None)
        ("-1", I32, -1),
        ("0x40200000", REAL32, 2.5),  # a REAL32's bit pattern (canopen: None)
        ("2.5", REAL32, 2.5),
        ("1", BOOLEAN, 1),
        (" 12 ", U8, 12),
    ],
)
def test_values_as_cia_306_writes_them(text: str, data_type: int, value: float) -> None:
    assert parse_value(text, data_type, 5) == value


@pytest.mark.parametrize(
    ("text", "data_type", "why"),
    [
        ("$NODEID+banana", U32, "'banana' is not a number"),
        ("0x1FF", U8, "511 does not fit the type (0 .. 255)"),
        ("65535", I16, "65535 does not fit the type (-32768 .. 32767)"),
        ("08", U8, "'08' is not a number"),
        ("$NODEID+$NODEID", U8, "$NODEID more than once"),
        ("1++2", U8, "'' is not a number"),
        ("2", BOOLEAN, "2 does not fit the type (0 .. 1)"),
        ("two", REAL32, "not a number"),
    ],
)
def test_values_that_are_not_values(text: str, data_type: int, why: str) -> None:
    with pytest.raises(ValueError, match=re.escape(why)):
        parse_value(text, data_type, 5)


def _with_value(tmp: pathlib.Path, index: str, value: str, key: str = "DefaultValue") -> pathlib.Path:
    text, n = re.subn(rf"(?s)(\[{index}\][^\[]*?){key}=[^\n]*", rf"\g<1>{key}={value}", EDS_TEXT)
    assert n == 1
    path = tmp / "drive.eds"
    path.write_text(text)
    return path


def test_an_unreadable_default_value_is_refused_naming_file_object_and_value(tmp_path: pathlib.Path) -> None:
    """Issue 33's probe: 0x6085 = $NODEID+banana was taken (canopen: None), and the emulated drive
    then aborted every read of it."""
    path = _with_value(tmp_path, "6085", "$NODEID+banana")
    with pytest.raises(ConfigError) as err:
        load_od(path, 1)
    assert str(err.value) == (
        f"{path}: object 0x6085:00 (Quick stop deceleration): DefaultValue=$NODEID+banana: 'banana' is "
        "not a number (decimal, 0x hexadecimal or 0 octal); correct the value in the file (CiA 306)"
    )


def test_a_dcf_parameter_value_is_read_too(tmp_path: pathlib.Path) -> None:
    text = EDS_TEXT.replace("[6085]\n", "[6085]\nParameterValue=0x1FFFFFFFF\n", 1)
    path = tmp_path / "drive.dcf"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"object 0x6085:00 .*ParameterValue=0x1FFFFFFFF: 8589934591 does"):
        load_od(path, 1)


def test_what_canopen_left_unread_is_read_and_served(tmp_path: pathlib.Path) -> None:
    """A value canopen could not read but CiA 306 allows is the object's value, which an emulated
    drive (canopen's LocalNode) then encodes."""
    path = _with_value(tmp_path, "6085", "$NODEID")
    od = load_od(path, 7)
    assert od[0x6085].default == 7
    assert od[0x6085].encode_raw(od[0x6085].default) == (7).to_bytes(4, "little")


def _numeric_values_readable(od: object) -> None:
    for var in variables(od):
        for raw, value in (
            (getattr(var, "default_raw", None), var.default),
            (getattr(var, "value_raw", None), var.value),
        ):
            if raw is None or not str(raw).strip() or var.data_type not in var.STRUCT_TYPES:
                continue
            assert value is not None, (hex(var.index), var.subindex, raw)
            var.encode_raw(value)  # what an emulated drive serves: never a "does not fit"


VALUE_LINES = [i for i, line in enumerate(EDS_TEXT.splitlines()) if line.startswith("DefaultValue=")]
values = st.one_of(
    st.text(max_size=12),
    st.integers(-(2**65), 2**65).map(str),
    st.integers(-(2**65), 2**65).map(hex),
    st.builds("{}+{}".format, st.sampled_from(["$NODEID", "0x180", "banana", "-1", ""]), st.text(max_size=6)),
    st.floats(allow_nan=True).map(repr),
)


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(VALUE_LINES), values), min_size=1, max_size=4))
def test_mutated_values_are_read_or_refused_in_one_line(changes: list[tuple[int, str]]) -> None:
    lines = EDS_TEXT.splitlines()
    for i, value in changes:
        lines[i] = "DefaultValue=" + value.replace("\n", " ").replace("\r", " ")
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "drive.eds"
        path.write_bytes("\n".join(lines).encode("utf-8", "replace"))
        try:
            od = load_od(path, 3)
        except ConfigError as exc:
            said = str(exc)
            assert said.startswith(str(path)) and "\n" not in said
            if "DefaultValue=" in said:
                assert re.search(r": object 0x[0-9A-F]{4}:[0-9A-F]{2} \(.+\): DefaultValue=", said), said
            return
    _numeric_values_readable(od)


def test_an_integer_of_cia_declared_another_type_is_refused(tmp_path: pathlib.Path) -> None:
    """0x6041 declared a string: the host would read text where it reads a statusword, and an
    emulated drive could not write its statusword."""
    path = _with_value(tmp_path, "6041", "0x0009", key="DataType")
    with pytest.raises(ConfigError) as err:
        load_od(path, 1)
    assert str(err.value) == (
        f"{path}: object 0x6041:00 (Statusword) is VISIBLE_STRING in the file; CiA 301/402 make it an "
        "integer: correct its DataType, or give the device's own EDS/DCF"
    )


def test_what_a_mode_needs_must_be_an_integer_variable(tmp_path: pathlib.Path) -> None:
    """The toolkit's voltage target 0x2100 (a manufacturer object, which CiA gives no type) declared
    REAL32: refused by what the voltage mode needs (``drivers.maps.cia402_needs``)."""
    from drivers.maps.cia import Mode
    from drivers.maps.cia402_needs import needed, require

    path = _with_value(tmp_path, "2100", "0x0008", key="DataType")
    with pytest.raises(
        ConfigError, match=r"0x2100 \(drive-rig's target voltage\) is REAL32, not the integer"
    ):
        require(load_od(path, 1), needed(Mode.VOLTAGE), source=str(path), what="mode voltage")
