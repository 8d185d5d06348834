"""Which columns of a run's rows the live view shows for each axis: its reference, its
measurement and its command, each with its unit (from ``rig.host.columns.describe_columns``).

- the law's first read axis: the law's ``reference`` and ``measurement`` (in the law's unit);
- any other axis: no reference, its measured quantity that its mode commands (CSP: position,
  CSV/PV/speed: velocity, CST: torque, voltage and an encoder: velocity, dq-voltage: current);
- every commanded axis (the law's or a profile's): its ``<axis>.command`` as sent.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

__all__ = ["Channel", "channels_of"]

#: the measured quantity shown for an axis in each mode (None: an encoder), best first
_MEASURED = {
    "csp": ("position",),
    "ip": ("position",),
    "csv": ("velocity",),
    "pv": ("velocity",),
    "speed": ("velocity",),
    "cst": ("torque", "velocity"),
    "voltage": ("velocity",),
    "dq-voltage": ("current",),
}
_ANY = ("velocity", "position", "torque", "current")


@dataclass(frozen=True)
class Channel:
    """One axis of the live view: column indices into a row (None: the axis has none) and units."""

    axis: str  #: the axis's name
    reference: int | None  #: the reference's column (None: none)
    measurement: int | None  #: the measurement's column
    command: int | None  #: the command's column
    measured: str  #: what the measurement is: "law" (the law's measurement) or a feedback field
    units: tuple[str, str, str]  #: of the reference, the measurement, the command

    @property
    def columns(self) -> tuple[int | None, int | None, int | None]:
        return self.reference, self.measurement, self.command


def channels_of(
    columns: Sequence[str],
    docs: Mapping[str, Mapping[str, str]],
    reads: Sequence[str],
    modes: Mapping[str, str | None],
) -> list[Channel]:
    """The channels of a run whose rows have ``columns`` (units in ``docs``), whose law reads
    the axes ``reads``, with the axes ``modes`` (name -> mode, None for an encoder) in order.

    Parameters
    ----------
    columns : Sequence[str]
        The rows' columns.
    docs : Mapping[str, Mapping[str, str]]
        Column -> its ``unit`` and ``doc``.
    reads : Sequence[str]
        The axes the law reads.
    modes : Mapping[str, str | None]
        Axis -> its mode (None: an encoder), in order.

    Returns
    -------
    list[Channel]
        The channels.
    """
    index = {c: i for i, c in enumerate(columns)}

    def unit(i: int | None) -> str:
        return docs.get(columns[i], {}).get("unit", "") if i is not None else ""

    channels = []
    for name, mode in modes.items():
        if reads and name == reads[0] and "reference" in index:
            ref, meas, measured = index["reference"], index.get("measurement"), "law"
        else:
            fields = [f for f in (*_MEASURED.get(mode or "", ("velocity",)), *_ANY) if f"{name}.{f}" in index]
            ref, measured = None, fields[0] if fields else ""
            meas = index[f"{name}.{measured}"] if fields else None
        cmd = index.get(f"{name}.command")
        if (ref, meas, cmd) != (None, None, None):
            channels.append(Channel(name, ref, meas, cmd, measured, (unit(ref), unit(meas), unit(cmd))))
    return channels
