"""An SDO answer canopen cannot read (shorter than the layout its first byte announces: a device
that cuts its frames, or another node sending on the drive's SDO COB-ID) is the toolkit's
``CommunicationError`` naming the node, the object and the COB-ID, not a ``struct.error`` out of
canopen's client (CiA 301: an SDO frame carries 8 data bytes). The independent fake device on
python-can's virtual bus answers one upload with such a frame."""

from __future__ import annotations

import pathlib
import struct

import pytest

from drivers.errors import CommunicationError
from tests.drivers.foreign import ForeignDrive


@pytest.mark.parametrize(
    "answer",
    [
        b"",  # no byte to read the command from
        b"\x55\xa2",  # cangen's 582#55A2 in the vcan VM
        b"\x43\x41\x60",  # an expedited upload answer cut before its sub-index
        b"\x80\x41\x60\x00",  # an abort without its code
        b"\x41\x41\x60\x00\x02",  # a segmented upload's size cut short
    ],
)
def test_an_sdo_answer_too_short_to_read_is_named(tmp_path: pathlib.Path, answer: bytes) -> None:
    with ForeignDrive("maxon-epos4", tmp_path) as drive:
        axis = drive.axis("csv")
        fake = drive.fake
        served = fake._sdo
        fake._sdo = lambda req: fake._send(0x581, answer)  # type: ignore[method-assign]
        with pytest.raises(CommunicationError) as err:
            axis.sdo_upload(0x6041)
        said = str(err.value)
        assert said.startswith("node 1: an SDO answer too short to read (SDO upload 0x6041:00"), said
        assert "COB-ID 0x581" in said and "8 data bytes" in said and "\n" not in said
        assert isinstance(err.value.__cause__, struct.error)
        fake._sdo = served  # type: ignore[method-assign]
        assert int.from_bytes(axis.sdo_upload(0x6041), "little") == fake.od.entries[(0x6041, 0)].value
