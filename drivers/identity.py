"""Who a CANopen device is (CiA 301 0x1018), read from the device, and the check of it against the
object dictionary in use, before the host writes anything but a read.

- ``Identity``: 0x1018 as the device answers (None: not readable), with the vendor's name: the
  EDS's where the dictionary in use is the device's own, else CiA's vendor list's
  (``drivers.maps.vendors``); ``toolkit`` is the positive identification of the
  toolkit's own drive (vendor 0xDB1, product 0x402), the one drive whose manufacturer objects and
  modes the host knows.
- ``STANDARD`` and ``read_standard``: the objects the host reads from every device by their
  standard's type (CiA 301, CiA 402), by SDO upload whatever the EDS in use names: identity,
  units and modes are the device's, never the EDS's default values. ``STANDARD_WRITES`` and
  ``encode_standard``: the few of them a move writes, by their standard's type, to a device met
  without its own dictionary.
- ``declared_identity``: what an EDS/DCF says its device is: 0x1018's default values, else
  [DeviceInfo]'s VendorNumber, ProductNumber and RevisionNumber.
- ``check_identity``: a device that is not the one its given dictionary describes (vendor or
  product code) is refused in one line naming both identities and the dictionary to give; a
  revision other than the dictionary's is a warning. Without a dictionary of the device's own
  (none given: the toolkit's generic CiA 402 one), nothing is compared: the device's units and
  modes are read from it, and nothing but standard objects is written.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from drivers.errors import ConfigError, SdoAbort
from drivers.maps import cia
from drivers.maps.logical import DEVICE_TYPE_OF_AXIS
from drivers.maps.vendors import vendor_of

__all__ = [
    "STANDARD",
    "STANDARD_WRITES",
    "TOOLKIT_DRIVE",
    "Identity",
    "check_identity",
    "declared_identity",
    "encode_standard",
    "read_identity",
    "read_standard",
    "vendor_name",
]

log = logging.getLogger(__name__)

TOOLKIT_DRIVE = (0xDB1, 0x402)  #: (vendor, product) of the toolkit's own drive (its EDS's 0x1018)

_U32, _I8, _U8, _I16, _I32 = (False, 4), (True, 1), (False, 1), (True, 2), (True, 4)
#: (signed, bytes) of the objects read from a device by their standard's type (CiA 301, CiA 402
#: and its older factor objects 0x6089-0x608C of DSP 402 v2)
STANDARD: Mapping[tuple[int, int], tuple[bool, int]] = {
    (cia.DEVICE_TYPE, 0): _U32,
    (DEVICE_TYPE_OF_AXIS, 0): _U32,  #: a logical device's type (``drivers.maps.logical``)
    **{(cia.IDENTITY, sub): _U32 for sub in (1, 2, 3, 4)},
    (cia.SUPPORTED_MODES, 0): _U32,
    **{(index, sub): _U32 for index in (0x608F, 0x6091, 0x6092) for sub in (1, 2)},
    (cia.SI_UNIT_POSITION, 0): _U32,
    (cia.SI_UNIT_VELOCITY, 0): _U32,
    (cia.POSITION_NOTATION, 0): _I8,
    (cia.POSITION_DIMENSION, 0): _U8,
    (cia.VELOCITY_NOTATION, 0): _I8,
    (cia.VELOCITY_DIMENSION, 0): _U8,
    (cia.RATED_CURRENT, 0): _U32,
    (cia.RATED_TORQUE, 0): _U32,
    (cia.POSITION_ACTUAL, 0): _I32,
    (cia.VELOCITY_ACTUAL, 0): _I32,
    (cia.TORQUE_ACTUAL, 0): _I16,
    (cia.STATUSWORD, 0): (False, 2),
    (cia.MODES_DISPLAY, 0): _I8,
    # what a drive's status shows besides (``rig.commission.picture``)
    (cia.ERROR_REGISTER, 0): _U8,
    (cia.ERROR_CODE, 0): (False, 2),
    (cia.ERROR_HISTORY, 0): _U8,
    **{(cia.ERROR_HISTORY, sub): _U32 for sub in range(1, 17)},
    (cia.SOFTWARE_POSITION_LIMIT, 1): _I32,
    (cia.SOFTWARE_POSITION_LIMIT, 2): _I32,
    (cia.MAX_MOTOR_SPEED, 0): _U32,
    (cia.MAX_TORQUE, 0): (False, 2),
    (cia.MAX_CURRENT, 0): (False, 2),
    (0x607F, 0): _U32,  # max profile velocity
    (cia.PROFILE_VELOCITY, 0): _U32,
    (cia.PROFILE_ACCELERATION, 0): _U32,
    (cia.PROFILE_DECELERATION, 0): _U32,
    (cia.QUICK_STOP_DECELERATION, 0): _U32,
    (cia.FOLLOWING_ERROR_WINDOW, 0): _U32,
    (cia.FOLLOWING_ERROR_TIMEOUT, 0): (False, 2),
    (cia.POSITION_WINDOW, 0): _U32,
    (cia.DIGITAL_INPUTS, 0): _U32,
    (cia.CURRENT_ACTUAL, 0): _I16,
    # homing (CiA 402: 0x6098 INTEGER8, 0x6099 ARRAY of UNSIGNED32, 0x609A UNSIGNED32)
    (cia.HOMING_METHOD, 0): _I8,
    (cia.HOMING_SPEEDS, 1): _U32,
    (cia.HOMING_SPEEDS, 2): _U32,
    (cia.HOMING_ACCELERATION, 0): _U32,
}

#: the entries of ``STANDARD`` CiA 402 declares writable (rw) that a commissioning move writes (its
#: profile's speed and ramps, a homing's method): where the dictionary in use is not the device's
#: own and does not name one, it is written by its standard's type (``encode_standard``) and the
#: device decides
STANDARD_WRITES = frozenset(
    {
        (cia.PROFILE_VELOCITY, 0),
        (cia.PROFILE_ACCELERATION, 0),
        (cia.PROFILE_DECELERATION, 0),
        (cia.HOMING_METHOD, 0),
    }
)


def encode_standard(index: int, subindex: int, value: float) -> bytes:
    """``value`` of (``index``, ``subindex``) of ``STANDARD`` in its standard's type, as sent.

    Parameters
    ----------
    index, subindex : int
        The object, an entry of ``STANDARD``.
    value : float
        Its value, a whole number.

    Returns
    -------
    bytes
        Little-endian, the type's size.

    Raises
    ------
    ValueError
        Not a whole number.
    OverflowError
        Outside the type's range.
    """
    signed, size = STANDARD[(index, subindex)]
    if not float(value).is_integer():
        raise ValueError(f"{value!r} is not an integer")
    return int(value).to_bytes(size, "little", signed=signed)


def read_standard(upload: Callable[[int, int], bytes], index: int, subindex: int = 0) -> int | None:
    """Object (``index``, ``subindex``) of ``STANDARD`` as the device answers ``upload`` (an SDO
    upload, raw bytes), by its standard's type; None where the device lacks it or refuses it (an
    abort). An answer of another size than the type's is decoded as sent (CiA 301 lets an
    expedited transfer say its size; a drive may keep an INTEGER32 object in two bytes).

    Parameters
    ----------
    upload : Callable[[int, int], bytes]
        An SDO upload: (index, subindex) -> the raw bytes answered.
    index, subindex : int
        The object, one of ``STANDARD``.

    Returns
    -------
    int | None
        Its value, or None where the device lacks or refuses it.
    """
    signed, _size = STANDARD[(index, subindex)]
    try:
        data = upload(index, subindex)
    except SdoAbort:
        return None
    if not data:
        return None
    return int.from_bytes(bytes(data[:8]), "little", signed=signed)


@dataclass(frozen=True)
class Identity:
    """0x1018 of a device (None: not readable or not given) and its vendor's name."""

    vendor: int | None = None  #: 0x1018 sub 1, the vendor-ID
    product: int | None = None  #: 0x1018 sub 2, the product code
    revision: int | None = None  #: 0x1018 sub 3, the revision number
    serial: int | None = None  #: 0x1018 sub 4, the serial number
    vendor_name: str = ""  #: the vendor's name ("": unknown)

    @property
    def toolkit(self) -> bool:
        """The toolkit's own drive, positively identified by vendor id and product code."""
        return (self.vendor, self.product) == TOOLKIT_DRIVE

    def as_dict(self) -> dict[str, int]:
        """The numbers known (``vendor``, ``product``, ``revision``, ``serial``).

        Returns
        -------
        dict[str, int]
            ``vendor``, ``product``, ``revision``, ``serial`` -> the numbers known.
        """
        fields = (("vendor", self.vendor), ("product", self.product), ("revision", self.revision))
        return {k: v for k, v in (*fields, ("serial", self.serial)) if v is not None}

    def text(self) -> str:
        """``vendor 0x000000FB (maxon motor ag) / product 0x65520000 / revision ... / serial ...``.

        Returns
        -------
        str
            The identity in words, the numbers in hex.
        """
        parts = []
        for key, value in self.as_dict().items():
            name = f" ({self.vendor_name})" if key == "vendor" and self.vendor_name else ""
            parts.append(f"{key} 0x{value:08X}{name}")
        return " / ".join(parts) or "no identity (0x1018 not readable)"


def read_identity(upload: Callable[[int, int], bytes]) -> Identity:
    """0x1018 sub 1-4 as the device answers (``read_standard``).

    Parameters
    ----------
    upload : Callable[[int, int], bytes]
        An SDO upload: (index, subindex) -> the raw bytes answered.

    Returns
    -------
    Identity
        0x1018 sub 1-4 as answered (None where not).
    """
    vendor, product, revision, serial = (read_standard(upload, cia.IDENTITY, sub) for sub in (1, 2, 3, 4))
    return Identity(vendor, product, revision, serial, vendor_name=vendor_of(vendor))


def vendor_name(od: Any) -> str:
    """The vendor's name an EDS gives ([DeviceInfo] VendorName), or "".

    Parameters
    ----------
    od : Any
        A canopen object dictionary read from an EDS/DCF.

    Returns
    -------
    str
        [DeviceInfo] VendorName, or "".
    """
    info: Any = getattr(od, "device_information", None)
    return str(getattr(info, "vendor_name", "") or "").strip()


def _default(od: Any, index: int, subindex: int) -> int | None:
    """An entry's default value where the EDS gives a number (not ``$NODEID``-relative or absent)."""
    try:
        value = od[index][subindex].default
    except (KeyError, TypeError, AttributeError):
        return None
    if not isinstance(value, int) or isinstance(value, bool):
        return None
    return value & 0xFFFFFFFF  # 0x1018's entries are UNSIGNED32 (an EDS declaring one signed: its bits)


def declared_identity(od: Any) -> Identity:
    """The identity an EDS/DCF declares: 0x1018 sub 1-3 default values, else [DeviceInfo]'s
    numbers (vendor, product code, revision; a serial number belongs to one device, not to its
    EDS).

    Parameters
    ----------
    od : Any
        A canopen object dictionary read from an EDS/DCF.

    Returns
    -------
    Identity
        Vendor, product and revision it declares (no serial).
    """
    info: Any = getattr(od, "device_information", None)
    numbers = [_default(od, cia.IDENTITY, sub) if cia.IDENTITY in od else None for sub in (1, 2, 3)]
    for i, key in enumerate(("vendor_number", "product_number", "revision_number")):
        if numbers[i] is None:
            value = getattr(info, key, None)
            numbers[i] = value if isinstance(value, int) else None
    vendor, product, revision = numbers
    return Identity(vendor, product, revision, vendor_name=vendor_name(od))


def check_identity(device: Identity, od: Any, *, eds: str, given: bool, where: str, give: str) -> Identity:
    """``device`` against the dictionary ``od`` (file ``eds``; ``given``: by the user, else the
    toolkit's generic one): the identity to use, with the vendor's name where the dictionary is
    the device's own. ConfigError where a given dictionary describes another device (vendor or
    product code); a warning where only the revision differs. ``give``: how the user gives the
    device's own dictionary (``--eds FILE``, the axis's ``eds`` key).

    Parameters
    ----------
    device : Identity
        The identity the device answers.
    od : Any
        The dictionary in use.
    eds : str
        Its file, named in messages.
    given : bool
        The user gave it (else the toolkit's generic one).
    where : str
        The device, named in messages (``node 3``).
    give : str
        How the user gives the device's own dictionary (``--eds FILE``).

    Returns
    -------
    Identity
        The identity to use, with the dictionary's vendor name.

    Raises
    ------
    ConfigError
        If a given dictionary's vendor or product code differs from the device's.
    """
    declared = declared_identity(od)
    if not given and not device.toolkit:
        log.info(
            "%s: %s; no EDS of its own was given: its units and modes are read from it, and only "
            "CiA 301/402 objects the standards declare writable are written (give %s for more)",
            where,
            device.text(),
            give,
        )
        return device
    for key in ("vendor", "product"):
        said, held = getattr(declared, key), getattr(device, key)
        if said is not None and held is not None and said != held:
            raise ConfigError(
                f"{where} is {device.text()}, but {eds} describes {declared.text()} ({key} differs): "
                f"nothing was written; give the device's own EDS/DCF ({give})"
            )
    if declared.revision is not None and device.revision is not None and declared.revision != device.revision:
        log.warning(
            "%s: revision 0x%08X, %s describes revision 0x%08X: objects may differ from its EDS",
            where,
            device.revision,
            eds,
            declared.revision,
        )
    return replace(device, vendor_name=declared.vendor_name or device.vendor_name)
