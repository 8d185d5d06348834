"""Protocol drivers (CANopen CiA 402/406, Modbus) and the shared protocol definitions.

Drivers know protocols and unit conversion, never physics or control laws.
"""

from drivers.errors import (
    CommunicationError,
    CommunicationTimeout,
    ConfigError,
    DeviceFault,
    ModbusExceptionResponse,
    RigError,
    SafetyStop,
    SdoAbort,
)

__all__ = [
    "CommunicationError",
    "CommunicationTimeout",
    "ConfigError",
    "DeviceFault",
    "ModbusExceptionResponse",
    "RigError",
    "SafetyStop",
    "SdoAbort",
]
