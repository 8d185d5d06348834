"""References of the controlled variable: (value, rate) as functions of time [s]."""

from __future__ import annotations

from drivers.profiles import parse_profile
from rig.config import ReferenceConfig
from rig.laws.base import Reference

__all__ = ["reference_of", "smooth_move"]


def smooth_move(distance: float, duration: float, start: float = 0.0) -> Reference:
    """A move by ``distance`` in ``duration`` from ``start``: quintic (minimum-jerk) profile.

    Parameters
    ----------
    distance : float
        The move [unit of the controlled variable].
    duration : float
        [s] its time.
    start : float
        [s] when it begins.

    Returns
    -------
    Reference
        t [s] -> (value, rate).
    """

    def ref(t: float) -> tuple[float, float]:
        s = min(max((t - start) / duration, 0.0), 1.0)
        pos = distance * s**3 * (10.0 - 15.0 * s + 6.0 * s * s)
        vel = distance * 30.0 * s * s * (1.0 - s) ** 2 / duration if 0.0 < s < 1.0 else 0.0
        return pos, vel

    return ref


def reference_of(cfg: ReferenceConfig) -> Reference:
    """The ``[reference]`` of a configuration (checked when it was loaded).

    Parameters
    ----------
    cfg : ReferenceConfig
        ``[reference]``.

    Returns
    -------
    Reference
        t [s] -> (value, rate).
    """
    if cfg.kind == "smooth-move":
        return smooth_move(cfg.distance, cfg.duration, cfg.start)
    if cfg.kind == "step":
        return lambda t: (cfg.value if t >= cfg.start else 0.0, 0.0)
    if cfg.kind == "constant":
        return lambda t: (cfg.value, 0.0)
    profile = parse_profile(cfg.profile)
    return lambda t: (profile(t), 0.0)
