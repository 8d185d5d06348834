"""CANopen wire constants: CiA 301 (communication) and CiA 402 (drives); CiA 406 in ``cia406``.

One definition for both sides of the wire: the host drivers (``drivers/``) and the emulated devices
(``plant_emulator/``) import these names, so neither writes an object index, a statusword mask, a
mode number or an NMT code as a literal. Object indices are module constants (the hot paths read
them every cycle); states, modes and commands are enums.

The manufacturer objects (0x2000-0x5FFF) here are the toolkit drive's own (``build_eds.py``)."""

from __future__ import annotations

import enum

from drivers.maps.pdo_entry import map_entry, split_map_entry
from drivers.maps.sdo_aborts import SdoAbortCode

__all__ = [
    "BOOT_UP",
    "CIA_MODE_BITS",
    "COB_EMCY",
    "COB_HEARTBEAT",
    "COB_NMT",
    "COB_RPDO",
    "COB_SDO_RX",
    "COB_SDO_TX",
    "COB_SYNC",
    "COB_TPDO",
    "COMMUNICATION_AREA",
    "MANUFACTURER_AREA",
    "MODE_BITS",
    "NODE_IDS",
    "PDO_INVALID",
    "SUPPORTED_MODE_BITS",
    "TARGET_OF_MODE",
    "AbortConnectionOption",
    "Controlword",
    "EmcyCode",
    "ErrorBehavior",
    "ErrorRegister",
    "Mode",
    "NmtCommand",
    "NmtState",
    "PowerState",
    "QuickStopOption",
    "SdoAbortCode",
    "decode_statusword",
    "map_entry",
    "split_map_entry",
]

# --- CiA 301 communication profile ---------------------------------------------------------
DEVICE_TYPE = 0x1000
ERROR_REGISTER = 0x1001
COB_ID_SYNC = 0x1005
COMM_CYCLE_PERIOD = 0x1006  #: [us]
ERROR_HISTORY = 0x1003  #: pre-defined error field: sub 0 the count, sub 1 the newest (code in the low word)
DEVICE_NAME = 0x1008
SOFTWARE_VERSION = 0x100A
STORE_PARAMETERS = 0x1010  #: sub 1 all, 2 communication, 3 application parameters
RESTORE_DEFAULTS = 0x1011  #: the same sub-indices
SAVE_SIGNATURE, LOAD_SIGNATURE = 0x65766173, 0x64616F6C  #: "save", "load" written as UNSIGNED32
COB_ID_EMCY = 0x1014
CONSUMER_HEARTBEAT = 0x1016  #: sub n: node id << 16 | time [ms]
PRODUCER_HEARTBEAT = 0x1017  #: [ms]
IDENTITY = 0x1018  #: sub 1 vendor, 2 product, 3 revision, 4 serial
ERROR_BEHAVIOR = 0x1029  #: sub 1: NMT state on a communication error (ErrorBehavior)
RPDO_COMM, RPDO_MAP = 0x1400, 0x1600  #: + n for RPDO n + 1
TPDO_COMM, TPDO_MAP = 0x1800, 0x1A00  #: + n for TPDO n + 1
PDO_COMM_COB_ID, PDO_COMM_TYPE, PDO_COMM_INHIBIT, PDO_COMM_EVENT_TIMER = 1, 2, 3, 5  #: subindices
PDO_INVALID = 0x80000000  #: COB-ID bit 31: the PDO does not exist (is being configured)
PDO_SYNC_MAX = 240  #: transmission types 1-240: every n-th SYNC; 254/255: event driven
PDO_EVENT_TYPES = (254, 255)
PDO_EVENT = 255  #: transmission type: event driven (device profile)
PDO_BLOCK = 0x200  #: objects per PDO parameter range (RPDO_COMM..RPDO_COMM + 0x1FF), also MAP - COMM
PDO_MAX_MAPPED = 8  #: mapped objects per PDO (byte granularity)
PDO_MAX_BITS = 64  #: data bits per PDO (one classic CAN frame)
COB_ID_MASK = 0x7FF  #: the 11-bit CAN identifier in a COB-ID entry
NODE_IDS = range(1, 128)  #: node ids a device may have
#: CiA 301 communication profile area: what NMT reset communication restores
COMMUNICATION_AREA = range(0x1000, 0x2000)
#: the manufacturer-specific area (CiA 301): each vendor's own meanings
MANUFACTURER_AREA = range(0x2000, 0x6000)


class EmcyCode(enum.IntEnum):
    """Emergency error codes (CiA 301 Table 21, CiA 402) the devices send; also in 0x603F."""

    NO_ERROR = 0x0000
    OVER_CURRENT = 0x2310  #: continuous over-current (device output side)
    COMMUNICATION = 0x8100  #: communication (generic): here, NMT took the node out of OPERATIONAL
    HEARTBEAT = 0x8130  #: life guard error or heartbeat error
    PDO_TOO_SHORT = 0x8210  #: PDO not processed due to length error
    PDO_TOO_LONG = 0x8220  #: PDO length exceeded
    RPDO_TIMEOUT = 0x8250  #: RPDO timeout (its event timer expired)
    OVER_SPEED = 0x8400  #: velocity speed controller (CiA 402): over-speed
    FOLLOWING_ERROR = 0x8611  #: positioning controller: following error


class ErrorRegister(enum.IntFlag):
    """Bits of the error register 0x1001 (CiA 301, 7.5.2.2)."""

    GENERIC = 0x01
    CURRENT = 0x02
    VOLTAGE = 0x04
    TEMPERATURE = 0x08
    COMMUNICATION = 0x10
    DEVICE_PROFILE = 0x20
    MANUFACTURER = 0x80


# COB-IDs of the predefined connection set (+ node id)
COB_NMT = 0x000
COB_SYNC = 0x080
COB_EMCY = 0x080
COB_TPDO = (0x180, 0x280, 0x380, 0x480)
COB_RPDO = (0x200, 0x300, 0x400, 0x500)
COB_SDO_TX = 0x580  #: server -> client
COB_SDO_RX = 0x600  #: client -> server
COB_HEARTBEAT = 0x700
BOOT_UP = 0x00  #: the one data byte of a boot-up message on COB_HEARTBEAT + node id


class NmtCommand(enum.IntEnum):
    """NMT command specifiers (first byte of the 2-byte frame on COB-ID 0)."""

    START = 0x01
    STOP = 0x02
    PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


class NmtState(enum.IntEnum):
    """NMT states as a heartbeat reports them."""

    INITIALISING = 0x00
    STOPPED = 0x04
    OPERATIONAL = 0x05
    PRE_OPERATIONAL = 0x7F

    @property
    def text(self) -> str:
        """The state as canopen spells it (``PRE-OPERATIONAL``)."""
        return self.name.replace("_", "-")


class ErrorBehavior(enum.IntEnum):
    """0x1029 sub 1 values: the NMT state a device takes on a communication error (CiA 301)."""

    PRE_OPERATIONAL = 0  #: if it was OPERATIONAL
    NO_CHANGE = 1
    STOPPED = 2


# --- CiA 402 drive profile --------------------------------------------------------------------
ABORT_CONNECTION_OPTION = 0x6007  #: AbortConnectionOption: the drive's reaction to a lost host
ERROR_CODE = 0x603F
CONTROLWORD = 0x6040
STATUSWORD = 0x6041
QUICK_STOP_OPTION = 0x605A
SHUTDOWN_OPTION = 0x605B
DISABLE_OPERATION_OPTION = 0x605C
HALT_OPTION = 0x605D
FAULT_REACTION_OPTION = 0x605E
MODES_OF_OPERATION = 0x6060
MODES_DISPLAY = 0x6061
POSITION_DEMAND = 0x6062  #: [position units] the position loop's demand
POSITION_ACTUAL = 0x6064  #: [position units]
FOLLOWING_ERROR_WINDOW = 0x6065  #: [position units]
FOLLOWING_ERROR_TIMEOUT = 0x6066  #: [ms]
POSITION_WINDOW = 0x6067  #: [position units] (profile position: target reached)
VELOCITY_ACTUAL = 0x606C  #: [velocity units]
VELOCITY_WINDOW = 0x606D  #: [velocity units] (profile velocity: target reached)
TARGET_TORQUE = 0x6071  #: [per mille of RATED_TORQUE]
MAX_TORQUE = 0x6072  #: [per mille of RATED_TORQUE]
MAX_CURRENT = 0x6073  #: [per mille of RATED_CURRENT]
RATED_CURRENT = 0x6075  #: [mA]
RATED_TORQUE = 0x6076  #: [mN m]
TORQUE_ACTUAL = 0x6077  #: [per mille]
CURRENT_ACTUAL = 0x6078  #: [per mille]
TARGET_POSITION = 0x607A  #: [position units]
HOME_OFFSET = 0x607C  #: [position units]
SOFTWARE_POSITION_LIMIT = 0x607D  #: sub 1 min, sub 2 max [position units]
MAX_MOTOR_SPEED = 0x6080  #: [rpm]
PROFILE_VELOCITY = 0x6081  #: [velocity units]
PROFILE_ACCELERATION = 0x6083
PROFILE_DECELERATION = 0x6084
QUICK_STOP_DECELERATION = 0x6085
#: DSP 402 v2's older unit objects: a power of ten (notation, INTEGER8) and a unit code (dimension,
#: UNSIGNED8) each for position and velocity (``drivers.maps.units.dimension_unit``)
POSITION_NOTATION = 0x6089
POSITION_DIMENSION = 0x608A
VELOCITY_NOTATION = 0x608B
VELOCITY_DIMENSION = 0x608C
POSITION_ENCODER_RESOLUTION = 0x608F  #: sub 1 increments, sub 2 motor revolutions
GEAR_RATIO = 0x6091
FEED_CONSTANT = 0x6092
HOMING_METHOD = 0x6098
HOMING_SPEEDS = 0x6099  #: sub 1 search for switch, sub 2 search for zero [velocity units]
HOMING_ACCELERATION = 0x609A
SI_UNIT_POSITION = 0x60A8
SI_UNIT_VELOCITY = 0x60A9
INTERPOLATION_SUBMODE, INTERPOLATION_DATA, INTERPOLATION_CONFIG = 0x60C0, 0x60C1, 0x60C4  #: ip mode's
INTERPOLATION_PERIOD = 0x60C2  #: sub 1 value, sub 2 index: the period is value x 10^index s
INTERPOLATION_SYNC = 0x60C3  #: sub 1 synchronize on group (0: SYNC), sub 2 ip sync every n event
FOLLOWING_ERROR_ACTUAL = 0x60F4
DIGITAL_INPUTS = 0x60FD  #: bit 0 negative limit switch, 1 positive limit switch, 2 home switch
TARGET_VELOCITY = 0x60FF  #: [velocity units]
SUPPORTED_MODES = 0x6502

# manufacturer objects of the toolkit's emulated drive
COMMAND_LATENCY = 0x2001  #: [us] an event RPDO takes effect this long after receipt
TARGET_VOLTAGE = 0x2100  #: [mV] mode -1
DQ_VOLTAGE = 0x2200  #: [mV] sub 1 u_d, sub 2 u_q, mode -2
DQ_CURRENT = 0x2210  #: [mA] sub 1 i_d, sub 2 i_q
FRAME_ANGLE = 0x2220  #: [urad]
FRAME_SPEED = 0x2221  #: [mrad/s]

# statusword bits beyond the state (CiA 402-2, 6.3)
SW_VOLTAGE_ENABLED = 0x0010
SW_WARNING = 0x0080
SW_REMOTE = 0x0200
SW_TARGET_REACHED = 0x0400
SW_FOLLOWS_COMMAND = 0x1000  #: bit 12 in the cyclic synchronous modes; ip mode active in ip
CW_ENABLE_IP = 0x0010  #: controlword bit 4 in ip: enable ip mode
SW_FOLLOWING_ERROR = 0x2000  #: bit 13


class PowerState(enum.Enum):
    """States of the CiA 402 power drive system; ``mask``/``bits`` decode the statusword."""

    NOT_READY_TO_SWITCH_ON = "NOT READY TO SWITCH ON"
    SWITCH_ON_DISABLED = "SWITCH ON DISABLED"
    READY_TO_SWITCH_ON = "READY TO SWITCH ON"
    SWITCHED_ON = "SWITCHED ON"
    OPERATION_ENABLED = "OPERATION ENABLED"
    QUICK_STOP_ACTIVE = "QUICK STOP ACTIVE"
    FAULT_REACTION_ACTIVE = "FAULT REACTION ACTIVE"
    FAULT = "FAULT"

    @property
    def mask(self) -> int:
        return _STATUS[self][0]

    @property
    def bits(self) -> int:
        """Statusword bits 0-6 of this state."""
        return _STATUS[self][1]

    @property
    def torque_off(self) -> bool:
        """The drive function is disabled: no torque (all states but OPERATION ENABLED, QUICK
        STOP ACTIVE and FAULT REACTION ACTIVE, which may still brake; CiA 402-2, 6.2)."""
        return self not in (
            PowerState.OPERATION_ENABLED,
            PowerState.QUICK_STOP_ACTIVE,
            PowerState.FAULT_REACTION_ACTIVE,
        )


#: statusword (mask, value) of each state: ready, switched on, operation enabled, fault,
#: voltage enabled (ignored), quick stop, switch on disabled
_STATUS = {
    PowerState.NOT_READY_TO_SWITCH_ON: (0x4F, 0x00),
    PowerState.SWITCH_ON_DISABLED: (0x4F, 0x40),
    PowerState.READY_TO_SWITCH_ON: (0x6F, 0x21),
    PowerState.SWITCHED_ON: (0x6F, 0x23),
    PowerState.OPERATION_ENABLED: (0x6F, 0x27),
    PowerState.QUICK_STOP_ACTIVE: (0x6F, 0x07),
    PowerState.FAULT_REACTION_ACTIVE: (0x4F, 0x0F),
    PowerState.FAULT: (0x4F, 0x08),
}
_BY_STATUS = {(mask, value): state for state, (mask, value) in _STATUS.items()}


def decode_statusword(statusword: int) -> PowerState | None:
    """The state a statusword reports, or None when its bits 0-6 encode none.

    Parameters
    ----------
    statusword : int
        0x6041.

    Returns
    -------
    PowerState | None
        The state; None where bits 0-6 encode none.
    """
    for (mask, value), state in _BY_STATUS.items():
        if statusword & mask == value:
            return state
    return None


class Controlword(enum.IntEnum):
    """Device control commands (controlword bits 0-3 and 7; CiA 402-2, 6.2)."""

    DISABLE_VOLTAGE = 0x00  #: transitions 7, 9, 10, 12
    QUICK_STOP = 0x02  #: transitions 7, 10, 11
    SHUTDOWN = 0x06  #: transitions 2, 6, 8
    SWITCH_ON = 0x07  #: transition 3 (and 5: disable operation)
    ENABLE_OPERATION = 0x0F  #: transitions 4, 16
    FAULT_RESET = 0x80  #: transition 15, on the rising edge

    @property
    def mask(self) -> int:
        """Controlword bits that select this command: ``cw & c.mask == c`` (bit 7 clear for the others)."""
        return _CW_MASK[self]


_CW_MASK = {
    Controlword.DISABLE_VOLTAGE: 0x02,
    Controlword.QUICK_STOP: 0x06,
    Controlword.SHUTDOWN: 0x07,
    Controlword.SWITCH_ON: 0x0F,
    Controlword.ENABLE_OPERATION: 0x0F,
    Controlword.FAULT_RESET: 0x80,
}


class QuickStopOption(enum.IntEnum):
    """Quick stop option codes (0x605A); 0-4 also code the fault reaction (0x605E).

    1-4 end in SWITCH ON DISABLED after the stop; 5-8 brake the same way and stay in
    QUICK STOP ACTIVE.
    """

    DISABLE_DRIVE = 0  #: power off at once: the motor coasts
    SLOW_DOWN_RAMP = 1
    QUICK_STOP_RAMP = 2
    CURRENT_LIMIT = 3
    VOLTAGE_LIMIT = 4
    SLOW_DOWN_RAMP_STAY = 5
    QUICK_STOP_RAMP_STAY = 6
    CURRENT_LIMIT_STAY = 7
    VOLTAGE_LIMIT_STAY = 8


class AbortConnectionOption(enum.IntEnum):
    """0x6007 values: what a drive does when its connection to the host is lost (CiA 402-2)."""

    NO_ACTION = 0
    FAULT = 1  #: fault signal: the fault reaction (0x605E), then FAULT
    DISABLE_VOLTAGE = 2  #: the power stage off: the motor coasts
    QUICK_STOP = 3  #: quick stop (0x605A)


class Mode(enum.IntEnum):
    """Modes of operation (0x6060); negative values are this toolkit's manufacturer modes."""

    PROFILE_POSITION = 1
    PROFILE_VELOCITY = 3
    PROFILE_TORQUE = 4
    HOMING = 6
    INTERPOLATED_POSITION = 7
    CSP = 8
    CSV = 9
    CST = 10
    VOLTAGE = -1  #: armature voltage [mV] in TARGET_VOLTAGE
    DQ_VOLTAGE = -2  #: dq voltage [mV] in DQ_VOLTAGE


#: the bit of 0x6502 (SUPPORTED_MODES) for each mode number CiA 402-2 defines, on every drive: pp 1,
#: vl 2, pv 3, tq 4, hm 6, ip 7, csp 8, csv 9, cst 10, cstca 11 (bits 4, 11-15 reserved; 16-31 vendors')
SUPPORTED_MODE_BITS = {1: 1 << 0, 2: 1 << 1, 3: 1 << 2, 4: 1 << 3, 6: 1 << 5, 7: 1 << 6}
SUPPORTED_MODE_BITS |= {8: 1 << 7, 9: 1 << 8, 10: 1 << 9, 11: 1 << 10}

#: the bits of 0x6502 that CiA 402 defines for the modes the toolkit drives (``Mode``)
CIA_MODE_BITS = {Mode(m): bit for m, bit in SUPPORTED_MODE_BITS.items() if m in Mode._value2member_map_}

#: bit of each mode in SUPPORTED_MODES (0x6502) on the toolkit's own drive: CiA's, and its voltage
#: modes in the manufacturer-specific bits 16 and 17, which on any other drive mean nothing
MODE_BITS = CIA_MODE_BITS | {Mode.VOLTAGE: 1 << 16, Mode.DQ_VOLTAGE: 1 << 17}

#: the target object (index, subindex) each scalar mode takes its command from
TARGET_OF_MODE = {
    Mode.VOLTAGE: (TARGET_VOLTAGE, 0),
    Mode.PROFILE_VELOCITY: (TARGET_VELOCITY, 0),
    Mode.CSP: (TARGET_POSITION, 0),
    Mode.INTERPOLATED_POSITION: (INTERPOLATION_DATA, 1),
    Mode.CSV: (TARGET_VELOCITY, 0),
    Mode.CST: (TARGET_TORQUE, 0),
}


PROFILE_DRIVE, PROFILE_ENCODER = 402, 406  #: device profile numbers in the low word of DEVICE_TYPE
