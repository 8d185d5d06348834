"""The emulated devices' SDO server: canopen's ``SdoServer`` with CiA 301's end of a transfer.

canopen's server keeps a segmented transfer's buffer and toggle bit after the transfer has
ended, so after an abort (its own, e.g. 0x05030000 toggle bit not alternated, or the
client's) the next segment request went on with the aborted transfer, a segment request
after the last segment got an empty segment (``1F 00 ...``), and a segment request before
any transfer raised inside the server (no answer at all). CiA 301 (7.2.4.3) ends a transfer
with its last segment or an abort; a segment request outside a segmented transfer of its
direction is answered with abort 0x05040001 (command specifier not valid), and a toggle bit
that did not alternate ends the transfer with abort 0x05030000. A new initiate request
starts a new transfer (canopen's server already does that).

The state is read from the server's own answers (an abort, an expedited or segmented
initiate answer, a last segment), so canopen's handlers are used unchanged.
"""

from __future__ import annotations

import struct
from typing import Any, Literal

from canopen.sdo.constants import (
    ABORT_GENERAL_ERROR,
    EXPEDITED,
    NO_MORE_DATA,
    REQUEST_ABORTED,
    REQUEST_SEGMENT_DOWNLOAD,
    REQUEST_SEGMENT_UPLOAD,
    RESPONSE_ABORTED,
    RESPONSE_DOWNLOAD,
    RESPONSE_SEGMENT_DOWNLOAD,
    RESPONSE_SEGMENT_UPLOAD,
    RESPONSE_UPLOAD,
)
from canopen.sdo.server import SdoServer as CanopenSdoServer

from drivers.maps.cia import SdoAbortCode

__all__ = ["SdoServer"]

Transfer = Literal["upload", "download"] | None
_SEGMENT_OF: dict[int, Transfer] = {REQUEST_SEGMENT_UPLOAD: "upload", REQUEST_SEGMENT_DOWNLOAD: "download"}
_CS = 0xE0  #: command specifier bits of byte 0


class SdoServer(CanopenSdoServer):
    """See the module docstring; ``transfer`` is the segmented transfer in progress, if any.

    Parameters
    ----------
    rx_cobid, tx_cobid : int
        The SDO's COB-IDs (client to server, server to client).
    node : Any
        The canopen ``LocalNode`` it serves.
    """

    def __init__(self, rx_cobid: int, tx_cobid: int, node: Any) -> None:
        super().__init__(rx_cobid, tx_cobid, node)  # type: ignore[no-untyped-call]
        self.transfer: Transfer = None
        self._request = b""

    def on_request(self, can_id: int, data: bytes, timestamp: float) -> None:
        """An SDO request: answered as canopen's server does, out-of-order segments aborted.

        Parameters
        ----------
        can_id : int
            The frame's identifier.
        data : bytes
            Its 8 bytes.
        timestamp : float
            [s] when it came.
        """
        ccs = data[0] & _CS if data else None
        if ccs == REQUEST_ABORTED:
            self.transfer = None  # no answer to an abort (CiA 301)
        elif ccs in _SEGMENT_OF:
            if self.transfer != _SEGMENT_OF[ccs]:
                self.abort(SdoAbortCode.COMMAND_SPECIFIER)
                return
        self._request = bytes(data)
        super().on_request(can_id, data, timestamp)  # type: ignore[no-untyped-call]

    def send_response(self, response: bytes | bytearray) -> None:
        """Send an answer, and note the transfer it begins or ends.

        Parameters
        ----------
        response : bytes | bytearray
            The 8 bytes.
        """
        scs = response[0] & _CS
        request = self._request
        if scs == RESPONSE_ABORTED:
            self.transfer = None
        elif scs == RESPONSE_UPLOAD:
            self.transfer = None if response[0] & EXPEDITED else "upload"
        elif scs == RESPONSE_DOWNLOAD:
            self.transfer = None if request[:1] and request[0] & EXPEDITED else "download"
        elif scs == RESPONSE_SEGMENT_UPLOAD and response[0] & NO_MORE_DATA:
            self.transfer = None
        elif scs == RESPONSE_SEGMENT_DOWNLOAD and request[:1] and request[0] & NO_MORE_DATA:
            self.transfer = None
        super().send_response(response)  # type: ignore[no-untyped-call]

    def abort(self, abort_code: int = ABORT_GENERAL_ERROR) -> None:
        """Abort the transfer with ``abort_code``: also before any transfer (index and sub-index 0).

        Parameters
        ----------
        abort_code : int, optional
            The SDO abort code (CiA 301).
        """
        if self._index is None:
            self.send_response(struct.pack("<BHBL", RESPONSE_ABORTED, 0, 0, abort_code))
            return
        super().abort(abort_code)  # type: ignore[no-untyped-call]
