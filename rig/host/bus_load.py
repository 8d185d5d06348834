"""How much of the bus a cycle takes: the worst-case bit times of its frames against the period.

Each period the bus carries a SYNC (0 bytes, whoever sends it) and every CANopen axis's frames
of the cycle (``CanopenAxis.cycle_frames``: its TPDOs, and a drive's RPDO, from the mapping in
force), each for ``drivers.bus_time.data_frame_bits`` (worst-case bit stuffing, Davis et
al. 2007) at the bit rate. ``bus_load`` is that over the period's bit times; above 1 the
frames of a cycle cannot all be on the bus within it, so answers queue and cycles come late:
the run goes on (the figure is a bound: real data stuff about 10 % fewer bits, and late cycles
are counted and may stop the run, ``[run] late_stop``), with one warning naming the period,
the bit rate and the frames, and what to change.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from drivers.bus_time import DEFAULT_BITRATE, data_frame_bits
from drivers.canopen_axis import CanopenAxis

__all__ = ["bus_load", "warn_bus_load"]

log = logging.getLogger(__name__)


def bus_load(axes: Sequence[CanopenAxis], period: float, bitrate: int) -> dict[str, Any]:
    """The cycle's bus figures for ``axes``: bits per cycle, the load and the frames, named.

    Parameters
    ----------
    axes : Sequence[CanopenAxis]
        The run's CANopen axes, their mapping in force.
    period : float
        The loop's period [s].
    bitrate : int
        ``[bus] bitrate`` [bit/s] (0: not configured, 1 Mbit/s assumed).

    Returns
    -------
    dict[str, Any]
        ``load`` (1 = the whole period), ``bits_per_cycle``, ``bitrate`` [bit/s],
        ``bitrate_assumed``, ``period_s`` [s] and ``frames`` (one text a frame).
    """
    rate = bitrate or DEFAULT_BITRATE
    frames = [("SYNC 0x080", 0)] + [
        (f"node {a.node_id} {what}", n) for a in axes for what, n in a.cycle_frames()
    ]
    bits = sum(data_frame_bits(n) for _, n in frames)
    return {
        "load": bits / (rate * period),
        "bits_per_cycle": bits,
        "bitrate": rate,
        "bitrate_assumed": not bitrate,
        "period_s": period,
        "frames": [f"{what}: {n} B, {data_frame_bits(n)} bits" for what, n in frames],
    }


def warn_bus_load(figures: dict[str, Any]) -> bool:
    """One warning when the cycle's frames take more than the period.

    Parameters
    ----------
    figures : dict[str, Any]
        What `bus_load` returned.

    Returns
    -------
    bool
        True where it warned (a load over 1).
    """
    if figures["load"] <= 1.0:
        return False
    assumed = " (assumed: [bus] bitrate is not set)" if figures["bitrate_assumed"] else ""
    log.warning(
        "the frames of a cycle take %d bit times with worst-case stuffing, %.0f %% of a period of "
        "%g s at %g kbit/s%s: %s; answers will queue and cycles come late: map fewer objects "
        "([[axis]] feedback), or take a longer period or a faster bus",
        figures["bits_per_cycle"],
        100.0 * figures["load"],
        figures["period_s"],
        figures["bitrate"] / 1000.0,
        assumed,
        "; ".join(figures["frames"]),
    )
    return True
