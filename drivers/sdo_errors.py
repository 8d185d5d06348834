"""canopen's SDO errors as the toolkit's (``drivers.errors``), translated once at the driver's
boundary, each naming the node and the object on the wire (axis 2's 0x6041 is 0x6841)."""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Iterator

import canopen
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from drivers.errors import (
    CommunicationError,
    CommunicationTimeout,
    DictionaryMismatch,
    NotInDictionary,
    SdoAbort,
)
from drivers.maps import cia
from drivers.maps.logical import axis_object
from drivers.maps.sdo_aborts import abort_text

__all__ = ["sdo_errors"]


@contextlib.contextmanager
def sdo_errors(what: str, index: int, subindex: int, *, node_id: int, axis: int, eds: str) -> Iterator[None]:
    """A context in which canopen's SDO errors (and an object the EDS lacks) become the toolkit's.

    Parameters
    ----------
    what : str
        What the transfer does, for the message (``SDO upload``).
    index, subindex : int
        The object, as axis 1 names it.
    node_id : int
        The node it goes to.
    axis : int
        The device's logical device (``drivers.maps.logical``).
    eds : str
        The EDS/DCF in use, for the message.

    Yields
    ------
    None
        The transfer runs in the context.

    Raises
    ------
    SdoAbort
        The device aborted the transfer.
    CommunicationTimeout
        No SDO answer.
    CommunicationError
        An answer too short to read (``struct.error`` in canopen's client).
    DictionaryMismatch
        The device's answer does not fit its type in ``eds``.
    NotInDictionary
        The dictionary in use lacks the object: nothing was sent.
    """
    index = axis_object(index, axis)
    try:
        yield
    except SdoAbortedError as exc:
        words = f"{what}: {abort_text(exc.code)}"
        raise SdoAbort(words, code=exc.code, node_id=node_id, index=index, subindex=subindex) from exc
    except SdoCommunicationError as exc:
        raise CommunicationTimeout(
            f"node {node_id}: no SDO answer ({what}, 0x{index:04X}:{subindex:02X})"
        ) from exc
    except struct.error as exc:  # canopen reads an answer by the layout its first byte announces
        raise CommunicationError(
            f"node {node_id}: an SDO answer too short to read ({what} 0x{index:04X}:{subindex:02X}: "
            f"canopen: {exc}): CiA 301 gives an SDO frame 8 data bytes; look on the bus (candump) for "
            f"another node sending on COB-ID 0x{cia.COB_SDO_TX + node_id:03X}, else the device cuts "
            "its frames"
        ) from exc
    except canopen.ObjectDictionaryError as exc:  # canopen's decoding of an answer it read itself
        raise DictionaryMismatch(
            f"node {node_id}: 0x{index:04X}:{subindex:02X}: {what}: {exc} (the device's answer does "
            f"not fit its type in {eds}): the EDS/DCF is not this device's; give the device's own"
        ) from exc
    except KeyError as exc:  # the dictionary in use lacks it: nothing was sent
        raise NotInDictionary(
            f"is not in {eds}: {what} not sent", node_id=node_id, index=index, subindex=subindex
        ) from exc
