"""An SDO answer whose size is not the type the EDS declares: one line naming node, object, file,
type and the bytes received (``drivers.sdo_answer``), never canopen's ObjectDictionaryError traceback
(issue 33: 0x1800:02 declared wider than the drive's answer)."""

from __future__ import annotations

import pathlib
import re
from collections.abc import Iterator

import pytest
from canopen.objectdictionary import ODVariable
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.errors import DictionaryMismatch
from drivers.sdo_answer import sized
from rig.cli import main
from tests.drivers.foreign import ForeignDrive

FUZZ = settings(max_examples=30, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))


def _var(data_type: int) -> ODVariable:
    var = ODVariable("Transmission type", 0x1800, 2)
    var.data_type = data_type
    return var


@pytest.mark.parametrize(
    ("data_type", "data", "indicated", "taken"),
    [
        (0x05, b"\x01", 1, b"\x01"),
        (0x05, b"\x01\x00\x00\x00", None, b"\x01"),  # expedited, size not indicated: the type's bytes
        (0x05, b"\x01\x00\x00\x00", 4, b"\x01"),  # a U8 answered as a U32 of the same value
        (0x03, b"\xfe\xff\xff\xff", 4, b"\xfe\xff"),  # -2 as INTEGER16, answered sign-extended
    ],
)
def test_answers_that_are_the_declared_value(
    data_type: int, data: bytes, indicated: int | None, taken: bytes
) -> None:
    assert sized(_var(data_type), data, indicated, node_id=1, source="d.eds") == taken


@pytest.mark.parametrize(
    ("data_type", "data", "indicated", "said"),
    [
        (0x07, b"\xff", 1, "is UNSIGNED32 (4 bytes) in d.eds, but the device answered 1 byte (ff)"),
        (0x05, b"\x00\x01", 2, "is UNSIGNED8 (1 byte) in d.eds, but the device answered 2 bytes (00 01)"),
        (0x03, b"\xfe\xff\x00\x00", 4, "is INTEGER16 (2 bytes) in d.eds, but the device answered 4 bytes"),
        (0x08, b"\x00" * 8, 8, "is REAL32 (4 bytes) in d.eds, but the device answered 8 bytes"),
    ],
)
def test_answers_of_another_size_are_refused(data_type: int, data: bytes, indicated: int, said: str) -> None:
    with pytest.raises(DictionaryMismatch) as err:
        sized(_var(data_type), data, indicated, node_id=1, source="d.eds")
    assert str(err.value).startswith("node 1: 0x1800:02 (Transmission type) " + said)


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ForeignDrive]:
    d = ForeignDrive("maxon-epos4", tmp_path_factory.mktemp("sizes"))
    yield d
    d.close()


TEXT_OF: dict[str, str] = {}
#: the types a mutation declares: CiA 301's integers, BOOLEAN, REAL32 and VISIBLE_STRING
TYPES = ["0x0001", "0x0002", "0x0003", "0x0004", "0x0005", "0x0006", "0x0007", "0x0008", "0x0009"]


@FUZZ
@given(st.data())
def test_status_on_an_eds_with_other_sizes_is_done_or_refused_in_one_line(
    drive: ForeignDrive, tmp_path_factory: pytest.TempPathFactory, data: st.DataObject
) -> None:
    text = TEXT_OF.setdefault(drive.eds, pathlib.Path(drive.eds).read_text())
    spots = [m for m in re.finditer(r"DataType=(0x000[2-7])", text)]
    chosen = data.draw(
        st.lists(st.sampled_from(spots), min_size=1, max_size=3, unique_by=lambda m: m.start())
    )
    changed = text
    for m in sorted(chosen, key=lambda m: -m.start()):
        new = data.draw(st.sampled_from(TYPES))
        changed = changed[: m.start(1)] + new + changed[m.end(1) :]
    path = tmp_path_factory.mktemp("eds") / "sized.eds"
    path.write_text(changed)
    capsys_err = _run_status(drive, path)
    if capsys_err:
        assert len(capsys_err.splitlines()) == 1 and str(path) in capsys_err, capsys_err


def _run_status(drive: ForeignDrive, path: pathlib.Path) -> str:
    """``rig drive status`` on ``path``: "" when done, else its one line on stderr (exit 2)."""
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(
            ["drive", "--interface", "virtual", "--channel", drive.channel, "--eds", str(path), "status"]
        )
    assert code in (0, 2), err.getvalue()
    return err.getvalue().strip() if code else ""
