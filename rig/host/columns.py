"""What each column of a run's samples means: name -> unit and meaning, for ``columns.json``
beside samples.csv and for the ``columns`` of samples.mat."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from drivers.base import AxisDriver
from rig.laws.base import Law

if TYPE_CHECKING:
    from rig.host.control import Wiring

__all__ = ["FIELDS", "MODE_UNITS", "TIMING", "describe_columns", "loop_columns"]

#: Feedback fields recorded per axis, in this order
FIELDS = ("position", "velocity", "torque", "current")
#: the columns after the row (``Recorder.sample``'s ``timing``): the stage times, then a real-time
#: run's response parts on the host's SYNC
TIMING = ("read_us", "update_us", "write_us", "answer_us", "host_us")


def loop_columns(axes: Sequence[AxisDriver], law: Law, wiring: Wiring, *, split: bool = False) -> list[str]:
    """The host loop's columns: law level, the law's internals, per axis, timing [us].

    Parameters
    ----------
    axes : Sequence[AxisDriver]
        The loop's axes.
    law : Law
        The run's law (its ``internals``).
    wiring : Wiring
        Which axes are commanded.
    split : bool
        A real-time run on the host's SYNC: the response's two parts (``answer_us``, ``host_us``) too.

    Returns
    -------
    list[str]
        The column names, in the samples' order.
    """
    per_axis = [f"{a.name}.{f}" for a in axes for f in FIELDS if f in a.measures]
    commands = [f"{axes[i].name}.command" for i in wiring.commanded]
    return [
        "t",
        "reference",
        "measurement",
        "command",
        *law.internals,
        *per_axis,
        *commands,
        "late",
        *(TIMING if split else TIMING[:3]),
    ]


#: the unit of an axis's command in each mode
MODE_UNITS = {
    "voltage": "V",
    "cst": "N m",
    "csv": "rad/s",
    "pv": "rad/s",
    "speed": "rad/s",
    "csp": "rad",
    "ip": "rad",
    "dq-voltage": "V",
}
#: (unit, meaning) of a law's internal columns, by name
INTERNALS = {
    "g": ("V s", "the switching function g_k = c_delta e_k of (7.30b) (|g|/T is in V)"),
    "u_i": ("V", "the switching integral u_I,k of (7.30c)"),
    "omega_ref": ("rad/s", "the position loop's speed reference of the cascade (VII.D)"),
    "i_q_ref": ("A", "the speed loop's q-current reference of the cascade (VII.D)"),
    "i_d": ("A", "the measured d-axis current"),
    "u_d": ("V", "the d-axis voltage command"),
    "u_q": ("V", "the q-axis voltage command"),
    "integral": ("", "the speed law's integral state"),
    "excitation": ("", "the excitation r added to the command (rig identify's closed-loop experiment)"),
    "sign_law": ("", "1 where the sliding-mode law was outside its linear region this cycle, else 0"),
}
_FIELDS = {
    "position": ("rad", "the axis's position"),
    "velocity": ("rad/s", "the axis's speed"),
    "torque": ("N m", "the axis's torque"),
    "current": ("A", "the axis's current"),
}


def describe_columns(
    columns: Sequence[str], axes: Sequence[AxisDriver], law: Law
) -> dict[str, dict[str, str]]:
    """Each recorded column's unit and meaning (``HostLoop.columns``).

    Parameters
    ----------
    columns : Sequence[str]
        The recorder's columns.
    axes : Sequence[AxisDriver]
        The loop's axes (their modes give the commands' units).
    law : Law
        The run's law (its ``error_unit``).

    Returns
    -------
    dict[str, dict[str, str]]
        column -> ``{"unit", "meaning"}``.
    """
    by_name = {a.name: a for a in axes}
    first = next((a for a in axes if a.mode is not None), None)
    known = {
        "t": ("s", "the time of the cycle: its index times the period"),
        "reference": (law.error_unit, "the law's reference for the measured variable"),
        "measurement": (law.error_unit, "the measured variable the law controls"),
        "command": (MODE_UNITS.get(first.mode or "", "") if first else "", "the law's first command"),
        "read_us": ("us", "time to read every axis's feedback in this cycle"),
        "update_us": ("us", "time to compute the law and check the commands"),
        "write_us": ("us", "time to send the commands"),
        "answer_us": (
            "us",
            "real time: the host's SYNC to the drives' last TPDO answering it (their answer)",
        ),
        "host_us": ("us", "real time: that TPDO to the commands sent (the host's own time)"),
        "late": ("", "1: the TPDOs answering this cycle's SYNC missed their budget ([run] answer_budget)"),
    }
    docs: dict[str, dict[str, str]] = {}
    for column in columns:
        axis, _, field = column.partition(".")
        if column in known:
            unit, meaning = known[column]
        elif field == "command" and axis in by_name:
            unit, meaning = MODE_UNITS.get(by_name[axis].mode or "", ""), f"the command sent to axis {axis}"
        elif field in _FIELDS:
            unit, meaning = _FIELDS[field][0], f"{_FIELDS[field][1]} ({axis})"
        else:
            unit, meaning = INTERNALS.get(column, ("", "an internal of the law"))
        docs[column] = {"unit": unit, "meaning": meaning}
    return docs
