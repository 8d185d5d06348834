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
known one, malformed: shorter or longer than its function's request, longer than the 253
bytes a PDU may have, a byte count that disagrees with its quantity; application protocol
section 6 gives each request's size, ``request_problem``). Frames with a function code of
128 and up are other servers' exception answers and are ignored. Addressing (which units
are answered, broadcasts) follows pymodbus' rules, as for the requests it decodes.

Every malformed frame, answered with an exception or dropped, is one warning line naming
the peer (its address and port; the serial device) and the frame's bytes (at most
``TOLD`` lines a connection, then one that says the rest go unlogged). Nothing a peer sends
ends in an exception out of the framing (asyncio's "data_received() call failed" and its
traceback): should one escape all the same, it is that one line and the connection is
dropped (on RTU the bytes received so far are).
"""

from __future__ import annotations

import asyncio
import collections
import logging
import struct
from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.exceptions import NoSuchIdException
from pymodbus.framer.rtu import FramerRTU
from pymodbus.pdu import DecodePDU, ExceptionResponse, ModbusPDU
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.server.requesthandler import ServerRequestHandler
from pymodbus.transport import CommType

__all__ = ["SpecSerialServer", "SpecTcpServer", "request_problem", "split_rtu", "split_tcp"]

log = logging.getLogger(__name__)
MAX_PDU = 253  #: [bytes] (application protocol 4.1)
#: [bytes] the longest RTU frame a byte count can announce (function 23: 10 + 255 + 3); a frame
#: longer than 256 (address, PDU, CRC) is still taken, to be answered with exception 03
MAX_RTU_FRAME = 268
MAX_RTU_ADDRESS = 247  #: 0 broadcast, 1..247 servers, 248..255 reserved
#: the largest MBAP length field taken: an ADU has at most 260 bytes (TCP/IP implementation
#: guide, 3.1.3), its length field 254; a few bytes more are still answered (exception 03)
MAX_TCP_LENGTH = 260
TOLD = 10  #: malformed frames logged per connection
SHOWN = 32  #: [bytes] of a frame shown in its line

#: [bytes] the request PDU of each function whose request has a fixed size (application
#: protocol V1.1b3, section 6: read coils .. write single register, read exception status,
#: get comm event counter and log, report server id, mask write register, read FIFO queue)
REQUEST_SIZE = {1: 5, 2: 5, 3: 5, 4: 5, 5: 5, 6: 5, 7: 1, 11: 1, 12: 1, 17: 1, 22: 7, 24: 3}

#: one frame: (unit id, transaction id (0 on RTU), PDU bytes)
Frame = tuple[int, int, bytes]


def split_tcp(data: bytes) -> tuple[list[Frame], bytes, tuple[bytes, str] | None]:
    """The Modbus ADUs complete in ``data``, the bytes left over (the start of the next), and the
    first ADU that is no Modbus request with why (then nothing after it is taken): a protocol id
    not 0, a length with no function code in it, or more than an ADU may hold (not waited for).

    Parameters
    ----------
    data : bytes
        The bytes received.

    Returns
    -------
    tuple[list[Frame], bytes, tuple[bytes, str] | None]
        (the complete ADUs, the bytes left over, the first bad ADU and why or None).
    """
    frames: list[Frame] = []
    pos = 0
    while len(data) - pos >= 6:
        tid, pid, length = struct.unpack_from(">HHH", data, pos)
        end = pos + 6 + length
        if length > MAX_TCP_LENGTH:
            return frames, b"", (data[pos:end], f"MBAP length {length}: more than {MAX_TCP_LENGTH}")
        if end > len(data):
            break
        if pid != 0 or length < 2:
            why = f"protocol id {pid}, not Modbus" if pid else f"MBAP length {length}: no function code"
            return frames, b"", (data[pos:end], why)
        frames.append((data[pos + 6], tid, data[pos + 7 : end]))
        pos = end
    return frames, data[pos:], None


def _rtu_size(frame: bytes, decoder: DecodePDU) -> int:
    """Length [bytes] of the RTU request that starts ``frame`` (at least 4 bytes): 0 while its
    byte count has not arrived, -1 when its function code is unknown."""
    try:
        pdu_class = decoder.lookupPduClass(frame)
        if pdu_class is None:
            return -1
        return int(pdu_class.calculateRtuFrameSize(frame))
    except Exception:  # pymodbus' guess at a frame of noise: whatever it raises, no size known
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
    noise before a frame is dropped, and so is anything too far back to begin one.

    Parameters
    ----------
    data : bytes
        The bytes received.
    decoder : DecodePDU
        pymodbus' PDU decoder.

    Returns
    -------
    tuple[list[Frame], bytes]
        (the frames whose CRC checks, the bytes kept).
    """
    frames: list[Frame] = []
    while (found := _find_rtu_frame(data, decoder)) is not None:
        start, end = found
        if start:
            log.debug("Modbus RTU: %d bytes of noise dropped", start)
        frames.append((data[start], 0, data[start + 1 : end - 2]))
        data = data[end:]
    return frames, data[-(MAX_RTU_FRAME - 1) :]


def request_problem(pdu: bytes) -> str:
    """What makes ``pdu``, a request of a function code the server knows, malformed (exception
    03), or "": a size other than its function's (application protocol V1.1b3, section 6), a
    byte count that disagrees with its quantity or with the bytes that follow it.

    Parameters
    ----------
    pdu : bytes
        A request's PDU.

    Returns
    -------
    str
        What makes it malformed; "" where nothing does.
    """
    fc, n = pdu[0], len(pdu)
    if n > MAX_PDU:
        return f"a PDU of {n} bytes (at most {MAX_PDU})"
    size = REQUEST_SIZE.get(fc)
    if size is not None:
        return "" if n == size else f"function 0x{fc:02X} with {n - 1} data bytes (its request: {size - 1})"
    if fc in (15, 16, 23):
        head = 10 if fc == 23 else 6  # 23: read start, quantity, write start, quantity, count
        if n < head:
            return f"function 0x{fc:02X} with {n - 1} data bytes (at least {head - 1})"
        quantity = int.from_bytes(pdu[head - 3 : head - 1], "big")
        need = (quantity + 7) // 8 if fc == 15 else 2 * quantity
        if pdu[head - 1] != need or n != head + need:
            return f"function 0x{fc:02X}: byte count {pdu[head - 1]} for {quantity} and {n - head} bytes"
        return ""
    if fc in (20, 21) and (n < 2 or n != 2 + pdu[1]):
        return f"function 0x{fc:02X}: byte count {pdu[1] if n > 1 else None} and {n - 2} bytes"
    if fc == 8 and n < 3:
        return "function 0x08 without its sub-function"
    if fc == 43 and (n < 2 or (pdu[1] == 14 and n != 4)):
        return "function 0x2B without its MEI type and codes"
    return ""


def _decoded(decoder: DecodePDU, pdu: bytes) -> ModbusPDU | None:
    """pymodbus' request of ``pdu``, or None where it cannot decode it (whatever it raises)."""
    try:
        return decoder.decode(pdu)
    except Exception:  # struct.error, IndexError ... on a malformed PDU pymodbus decodes blindly
        return None


def _retrieved(task: asyncio.Task[None]) -> None:
    """A drain's outcome, taken: a stop (Ctrl-C, SIGTERM) that landed while it ran has gone on out
    of the loop and stops the server; asyncio need not also log it as "never retrieved"."""
    if not task.cancelled():
        task.exception()


class _Handler(ServerRequestHandler):
    """One connection (a TCP client, or the serial line): every request in the bytes, in order."""

    def __init__(self, owner: Any) -> None:
        trace = (owner.trace_packet, owner.trace_pdu, owner.trace_connect)
        super().__init__(owner, *trace)  # type: ignore[no-untyped-call]
        self.rtu = owner.comm_params.comm_type == CommType.SERIAL
        self._bytes = b""
        self._queue: collections.deque[tuple[ModbusPDU, Any]] = collections.deque()
        self._drainer: asyncio.Task[None] | None = None
        self._peer = ""
        self._told = 0  #: malformed frames logged on this connection
        self._dropping = False  #: the stream is no Modbus: answer what came before, then close

    def callback_data(self, data: bytes, addr: tuple[Any, ...] | None = None) -> int:
        """Frame the bytes, queue every request; all bytes are taken (what is left is kept here).
        Nothing a peer sends raises out of here (see the module docstring)."""
        try:
            self._take(data, addr)
        except Exception as exc:
            self.tell(self._bytes or data, f"{type(exc).__name__}: {exc}")
            self._drop()
        return len(data)

    def _take(self, data: bytes, addr: tuple[Any, ...] | None) -> None:
        if self._dropping:
            return
        self._bytes += data
        bad = None
        if self.rtu:
            frames, self._bytes = split_rtu(self._bytes, self.server.decoder)
        else:
            frames, self._bytes, bad = split_tcp(self._bytes)
        for unit, tid, pdu in frames:  # (an exception answer's function code on TCP ends them)
            self._enqueue(unit, tid, pdu, addr)
            if self._dropping:
                break
        if bad is not None and not self._dropping:  # no Modbus from here on (TCP):
            self.tell(bad[0], f"{bad[1]}: connection closed")  # what came before is answered
            self._dropping = True
        if self._queue and (self._drainer is None or self._drainer.done()):
            self._drainer = asyncio.get_running_loop().create_task(self._drain())
            self._drainer.add_done_callback(_retrieved)
        elif self._dropping and (self._drainer is None or self._drainer.done()):
            self._drop()  # (a drain under way drops at its end)

    def _drop(self) -> None:
        """Forget the bytes received; on TCP close the connection (the line of RTU stays)."""
        self._bytes, self._dropping = b"", not self.rtu
        if not self.rtu and self.transport:
            self.transport.close()

    def peer(self) -> str:
        """Who sent the bytes: the TCP client's address and port, or the serial device."""
        if not self._peer:
            info = self.transport.get_extra_info("peername") if self.transport else None
            where = f"{info[0]}:{info[1]}" if isinstance(info, tuple) and len(info) >= 2 else "a client"
            self._peer = str(self.server.comm_params.source_address[0]) if self.rtu else where
        return self._peer

    def tell(self, frame: bytes, what: str) -> None:
        """One warning line naming the peer and ``frame`` (its first ``SHOWN`` bytes); at most
        ``TOLD`` a connection."""
        self._told += 1
        if self._told > TOLD + 1:
            return
        kind = "RTU" if self.rtu else "TCP"
        if self._told > TOLD:
            log.warning("Modbus %s %s: more malformed frames, not logged", kind, self.peer())
            return
        shown = frame[:SHOWN].hex(" ") + (" ..." if len(frame) > SHOWN else "")
        log.warning("Modbus %s %s: frame %s: %s", kind, self.peer(), shown or "(empty)", what)

    def _enqueue(self, unit: int, tid: int, pdu: bytes, addr: Any) -> None:
        adu = bytes([unit]) + pdu if self.rtu else struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu
        if pdu[0] & 0x80:
            if not self.rtu:  # on a line, another server's exception answer; on TCP, nobody's request
                self.tell(adu, f"function code 0x{pdu[0]:02X} is an exception answer's: connection closed")
                self._dropping = True
            return
        known = pdu[0] in self.server.decoder.pdu_table
        problem = request_problem(pdu) if known else f"function code 0x{pdu[0]:02X} is not one the server has"
        request = None if problem else _decoded(self.server.decoder, pdu)
        if request is None:
            code = ExcCodes.ILLEGAL_VALUE if known else ExcCodes.ILLEGAL_FUNCTION
            self.tell(adu, f"{problem or 'not a request pymodbus decodes'}: exception {int(code):02X}")
            answer = ExceptionResponse(pdu[0], code, device_id=unit, transaction=tid)
            self._queue.append((answer, addr))
            return
        request.dev_id, request.transaction_id = unit, tid
        self._queue.append((request, addr))

    async def _drain(self) -> None:
        """Handle the queued requests one after the other (pymodbus' ``handle_request`` each)."""
        while self._queue:
            pdu, addr = self._queue.popleft()
            try:
                if isinstance(pdu, ExceptionResponse):  # the answer to a request that could not be decoded
                    answer = self._route(pdu)
                    if answer is not None:
                        self.server_send(answer, addr)  # type: ignore[no-untyped-call]
                    continue
                self.last_pdu, self.last_addr = pdu, addr
                await self.handle_request()  # type: ignore[no-untyped-call]
            except Exception as exc:  # a request pymodbus could not answer: one line, the next goes on
                self.tell(pdu.encode() if hasattr(pdu, "encode") else b"", f"not answered: {exc}")
        if self._dropping:
            self._drop()

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
        """A handler with this module's framing for a new connection.

        Returns
        -------
        _Handler
            The handler.
        """
        return _Handler(self)


class SpecSerialServer(ModbusSerialServer):
    """pymodbus' serial server with this module's RTU framing."""

    def callback_new_connection(self) -> _Handler:
        """A handler with this module's RTU framing for the serial line.

        Returns
        -------
        _Handler
            The handler.
        """
        return _Handler(self)
