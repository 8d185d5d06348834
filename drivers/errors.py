"""The toolkit's exception tree.

It lives in the lowest layer that raises it (``drivers``), so that ``drivers``,
``plant_emulator`` and ``rig`` share one root without importing upwards.
``controllers`` stays pure and raises plain ``ValueError``; ``rig`` translates.

::

    RigError
     +-- ConfigError (ValueError)          bad configuration or argument
     |    +-- DictionaryMismatch            the device answers unlike its EDS/DCF says
     +-- CommunicationError                 the bus or the line failed
     |    +-- CommunicationTimeout (TimeoutError)
     |    |    +-- NodeSilent                no SDO answer at all: no such node on the bus?
     |    +-- SdoAbort                      SDO abort, ``.code`` (CiA 301)
     |    |    +-- NotInDictionary           not written: the EDS/DCF in use lacks the object
     |    +-- ModbusExceptionResponse       ``.code`` (Modbus exception code)
     +-- DeviceFault                        the device reports a fault (EMCY, ...)
     +-- SafetyStop                         the host stopped the drive on purpose
     +-- StorageError                       the run directory could not be written

Library exceptions are translated at the driver boundary with
``raise ... from exc``.
"""

from __future__ import annotations

__all__ = [
    "MODBUS_EXCEPTIONS",
    "CommunicationError",
    "CommunicationTimeout",
    "ConfigError",
    "DeviceFault",
    "DictionaryMismatch",
    "ModbusExceptionResponse",
    "NodeSilent",
    "NotInDictionary",
    "RigError",
    "SafetyStop",
    "SdoAbort",
    "StorageError",
    "brief",
]


class RigError(Exception):
    """Root of every error the toolkit raises on purpose."""


class ConfigError(RigError, ValueError):
    """A configuration value or command-line argument is wrong.

    The message names the value and where it came from (file, key, option).
    """


class DictionaryMismatch(ConfigError):
    """The device's answer disagrees with the EDS/DCF in use (an object's size is not its type's):
    the dictionary is not this device's. The message names node, object, file, type and answer."""


class CommunicationError(RigError):
    """A bus, line or device did not communicate as the protocol requires."""


class CommunicationTimeout(CommunicationError, TimeoutError):
    """No answer within the timeout (seconds)."""


class NodeSilent(CommunicationTimeout):
    """A node never answered its first SDO request: a wrong node id, or a node not powered."""


class SdoAbort(CommunicationError):
    """An SDO transfer was aborted.

    Parameters
    ----------
    message : str
        What was being done.
    code : int
        The 32-bit CiA 301 abort code.
    node_id : int
        The node that aborted (or was aborted).
    index, subindex : int
        The object of the transfer.
    """

    def __init__(self, message: str, *, code: int, node_id: int, index: int, subindex: int):
        super().__init__(f"{message} (node {node_id}, 0x{index:04X}:{subindex:02X}, abort code 0x{code:08X})")
        self.code = code
        self.node_id = node_id
        self.index = index
        self.subindex = subindex


class NotInDictionary(SdoAbort):
    """A write not sent: the EDS/DCF in use does not name the object. Nothing reached the device;
    ``.code`` is what the dictionary says of the object (CiA 301's 0x06090011, no such sub-index),
    so a caller taking an abort as "the device lacks it" takes this so too.

    Parameters
    ----------
    message : str
        Why it was not sent (the file that lacks it, the write).
    node_id : int
        The node it was for.
    index, subindex : int
        The object.
    """

    def __init__(self, message: str, *, node_id: int, index: int, subindex: int):
        CommunicationError.__init__(self, f"node {node_id}: 0x{index:04X}:{subindex:02X} {message}")
        self.code = 0x06090011
        self.node_id = node_id
        self.index = index
        self.subindex = subindex


#: Modbus exception codes and their names (Modbus Application Protocol V1.1b3, section 7)
MODBUS_EXCEPTIONS = {
    0x01: "illegal function",
    0x02: "illegal data address",
    0x03: "illegal data value",
    0x04: "server device failure",
    0x05: "acknowledge",
    0x06: "server device busy",
    0x08: "memory parity error",
    0x0A: "gateway path unavailable",
    0x0B: "gateway target device failed to respond",
}


class ModbusExceptionResponse(CommunicationError):
    """A Modbus device answered with an exception.

    Parameters
    ----------
    message : str
        What was being done.
    code : int
        The exception code (``MODBUS_EXCEPTIONS``).
    unit : int
        The device's unit id.
    register : int
        The first register of the request.
    """

    def __init__(self, message: str, *, code: int, unit: int, register: int):
        name = MODBUS_EXCEPTIONS.get(code, "not a code of the specification")
        super().__init__(f"{message} (unit {unit}, register {register}, exception code {code}: {name})")
        self.code = code
        self.unit = unit
        self.register = register


class DeviceFault(RigError):
    """The device reports a fault.

    Parameters
    ----------
    message : str
        The fault in words.
    device : str
        The device, as the message names it (``node 3``, ``unit 1``).
    code : int
        Its error code (an EMCY code, 0x603F, an inverter's fault register), 0 if none.
    """

    def __init__(self, message: str, *, device: str, code: int = 0):
        named = not code or f"0x{code:04X}" in message  # an EMCY's text names its code already
        super().__init__(f"{device}: {message}" + ("" if named else f" (error code 0x{code:04X})"))
        self.device = device
        self.code = code


class SafetyStop(RigError):
    """The host loop stopped the drive through the safe-stop path.

    Parameters
    ----------
    reason : str
        Why, in words.
    """

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


class StorageError(RigError):
    """A file of the run directory could not be written (disk full, directory removed, ...)."""


def brief(exc: BaseException) -> str:
    """An exception's words without the traceback text python-can puts in some of them.

    Parameters
    ----------
    exc : BaseException
        The exception.

    Returns
    -------
    str
        Its message, up to any traceback text.
    """
    return str(exc).split("Traceback (most recent call last)")[0].strip()
