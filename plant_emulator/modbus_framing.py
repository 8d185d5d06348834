"""Modbus TCP and RTU framing for the emulated inverter's pymodbus servers, as the specifications have it.

pymodbus 3.11's server handles one request per ``data_received`` (a second request in
the same TCP segment waits, unanswered, for more bytes), answers an unknown function
code with function code 0xA8 and transaction 0, and its RTU framer waits for as many
bytes as a noise byte that looks like a byte count asks for, so 36 bytes of line noise
silence it for good. pymodbus' own settings do the addressing (``ignore_missing_devices``,
``broadcast_enable``, the unit ids of the server context); this module only frames:

- TCP (Messaging on TCP/IP implementation guide V1.0b): the MBAP header's length field
  delimits each ADU, and every complete one in the bytes received is answered, in
  order. An ADU whose protocol identifier is not 0 (not Modbus), or that holds no
  function code (length < 2), is dropped.
- RTU (Modbus over serial line V1.02): a frame is what lies between silent intervals
  t3.5, which a pseudo-terminal does not keep. Instead, the first complete frame whose
  CRC checks is taken wherever it starts in the bytes received, and what precedes it is
  dropped as noise; a request whose function code is unknown, so whose length is not,
  is taken to end where the bytes received end (a master writes a frame in one go).
  Nothing that can still begin a frame is dropped and nothing can block a later frame,
  so the line resynchronises on the first sound frame after any noise; a false match
  of the CRC-16 has a chance of 2^-16 per candidate start.

A request that cannot be decoded gets exception 01 (unknown function code) or 03 (a
known one, malformed, longer than the 253 bytes a PDU may have, or a byte count that
disagrees with its quantity). Frames with a function code of 128 and up are other
servers' exception answers and are ignored. Addressing (which units are answered,
broadcasts) follows pymodbus' rules, as for the requests it decodes.
"""

from __future__ import annotations

import asyncio
import collections
import logging
import struct
from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.exceptions import ModbusException, NoSuchIdException
from pymodbus.framer.rtu import FramerRTU
from pymodbus.pdu import DecodePDU, ExceptionResponse, ModbusPDU
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.server.requesthandler import ServerRequestHandler
from pymodbus.transport import CommType

__all__ = ["SpecSerialServer", "SpecTcpServer", "split_rtu", "split_tcp"]

log = logging.getLogger(__name__)
MAX_PDU = 253  #: [bytes] (application protocol 4.1)
#: [bytes] the longest RTU frame a byte count can announce (function 23: 10 + 255 + 3); a frame
#: longer than 256 (address, PDU, CRC) is still taken, to be answered with exception 03
MAX_RTU_FRAME = 268
MAX_RTU_ADDRESS = 247  #: 0 broadcast, 1..247 servers, 248..255 reserved

#: one frame: (unit id, transaction id (0 on RTU), PDU bytes)
Frame = tuple[int, int, bytes]


def split_tcp(data: bytes) -> tuple[list[Frame], bytes]:
    """The Modbus ADUs complete in ``data``, and the bytes left over (the start of the next)."""
    frames: list[Frame] = []
    pos = 0
    while len(data) - pos >= 6:
        tid, pid, length = struct.unpack_from(">HHH", data, pos)
        end = pos + 6 + length
        if end > len(data):
            break
        if pid == 0 and length >= 2:
            frames.append((data[pos + 6], tid, data[pos + 7 : end]))
        else:
            log.debug("Modbus TCP: ADU of protocol id %d, length %d dropped: no Modbus request", pid, length)
        pos = end
    return frames, data[pos:]


def _rtu_size(frame: bytes, decoder: DecodePDU) -> int:
    """Length [bytes] of the RTU request that starts ``frame`` (at least 4 bytes): 0 while its
    byte count has not arrived, -1 when its function code is unknown."""
    try:
        pdu_class = decoder.lookupPduClass(frame)
        if pdu_class is None:
            return -1
        return int(pdu_class.calculateRtuFrameSize(frame))
    except (ModbusException, IndexError):
        return -1


def _find_rtu_frame(data: bytes, decoder: DecodePDU) -> tuple[int, int] | None:
    """(start, end) of the first complete frame in ``data`` whose CRC checks, or None."""
    n = len(data)
    for start in range(n - 3):
        if data[start] > MAX_RTU_ADDRESS:
            continue
        size = _rtu_size(data[start:], decoder)
        if size < 0:
            size = n - start  # unknown function code: the frame ends with the bytes received
        if not 4 <= size <= MAX_RTU_FRAME or start + size > n:
            continue  # not complete (yet): a later start may be
        body, crc = data[start : start + size - 2], data[start + size - 2 : start + size]
        if FramerRTU.check_CRC(body, int.from_bytes(crc, "big")):
            return start, start + size
    return None


def split_rtu(data: bytes, decoder: DecodePDU) -> tuple[list[Frame], bytes]:
    """The complete RTU frames in ``data`` whose CRC checks, and the bytes kept for the next call:
    noise before a frame is dropped, and so is anything too far back to begin one."""
    frames: list[Frame] = []
    while (found := _find_rtu_frame(data, decoder)) is not None:
        start, end = found
        if start:
            log.debug("Modbus RTU: %d bytes of noise dropped", start)
        frames.append((data[start], 0, data[start + 1 : end - 2]))
        data = data[end:]
    return frames, data[-(MAX_RTU_FRAME - 1) :]


def _malformed(pdu: bytes) -> bool:
    """A write-multiple request whose byte count is not what its quantity needs (exception 03)."""
    if pdu[0] == 16 and len(pdu) >= 6:
        return pdu[5] != 2 * int.from_bytes(pdu[3:5], "big") or len(pdu) != 6 + pdu[5]
    if pdu[0] == 15 and len(pdu) >= 6:
        return pdu[5] != (int.from_bytes(pdu[3:5], "big") + 7) // 8 or len(pdu) != 6 + pdu[5]
    return False


class _Handler(ServerRequestHandler):
    """One connection (a TCP client, or the serial line): every request in the bytes, in order."""

    def __init__(self, owner: Any) -> None:
        trace = (owner.trace_packet, owner.trace_pdu, owner.trace_connect)
        super().__init__(owner, *trace)  # type: ignore[no-untyped-call]
        self.rtu = owner.comm_params.comm_type == CommType.SERIAL
        self._bytes = b""
        self._queue: collections.deque[tuple[ModbusPDU, Any]] = collections.deque()
        self._drainer: asyncio.Task[None] | None = None

    def callback_data(self, data: bytes, addr: tuple[Any, ...] | None = None) -> int:
        """Frame the bytes, queue every request; all bytes are taken (what is left is kept here)."""
        self._bytes += data
        if self.rtu:
            frames, self._bytes = split_rtu(self._bytes, self.server.decoder)
        else:
            frames, self._bytes = split_tcp(self._bytes)
        for unit, tid, pdu in frames:
            self._enqueue(unit, tid, pdu, addr)
        if self._queue and (self._drainer is None or self._drainer.done()):
            self._drainer = asyncio.get_running_loop().create_task(self._drain())
        return len(data)

    def _enqueue(self, unit: int, tid: int, pdu: bytes, addr: Any) -> None:
        if pdu[0] & 0x80:
            return  # an exception answer of another server (RTU), never a request
        request = None if len(pdu) > MAX_PDU or _malformed(pdu) else self.server.decoder.decode(pdu)
        if request is None:
            known = pdu[0] in self.server.decoder.pdu_table
            code = ExcCodes.ILLEGAL_VALUE if known else ExcCodes.ILLEGAL_FUNCTION
            answer = ExceptionResponse(pdu[0], code, device_id=unit, transaction=tid)
            self._queue.append((answer, addr))
            return
        request.dev_id, request.transaction_id = unit, tid
        self._queue.append((request, addr))

    async def _drain(self) -> None:
        """Handle the queued requests one after the other (pymodbus' ``handle_request`` each)."""
        while self._queue:
            pdu, addr = self._queue.popleft()
            if isinstance(pdu, ExceptionResponse):  # the answer to a request that could not be decoded
                answer = self._route(pdu)
                if answer is not None:
                    self.server_send(answer, addr)  # type: ignore[no-untyped-call]
                continue
            self.last_pdu, self.last_addr = pdu, addr
            await self.handle_request()  # type: ignore[no-untyped-call]

    def _route(self, answer: ExceptionResponse) -> ExceptionResponse | None:
        """What a request that could not be decoded gets, by pymodbus' addressing rules: nothing for
        a broadcast or an ignored unit, exception 0B for a unit not served, else ``answer``."""
        unit = answer.dev_id
        if unit == 0 and self.server.broadcast_enable:
            return None
        try:
            self.server.context[unit]
        except NoSuchIdException:
            if self.server.ignore_missing_devices:
                return None
            code, tid = ExcCodes.GATEWAY_NO_RESPONSE, answer.transaction_id
            return ExceptionResponse(answer.function_code, code, device_id=unit, transaction=tid)
        return answer


class SpecTcpServer(ModbusTcpServer):
    """pymodbus' TCP server with this module's framing."""

    def callback_new_connection(self) -> _Handler:
        return _Handler(self)


class SpecSerialServer(ModbusSerialServer):
    """pymodbus' serial server with this module's RTU framing."""

    def callback_new_connection(self) -> _Handler:
        return _Handler(self)
