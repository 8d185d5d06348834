"""The stability edge a study's plots draw: the plant b_m at which the position servo's (7.30)
becomes unstable in its linear mode, from the eigenvalues of its closed loop with the plant's
armature lag and the bus's delay (``controllers.servo_loop.gain_edge``).

It is drawn where a study of a configuration base varies ``emulator.params.b_m`` and the base
(with a point's other values) runs ``position-servo`` with (7.30) on an emulated dc-servo plant
(a preset or a twin with its physics) in voltage mode: the design is the law's at the run's
period, the plant the emulated one (a_m, tau_e), the delay the commanded axis's (an RPDO applied
at the next SYNC: a period; one applied on receipt: its latency, 0x2001).
"""

from __future__ import annotations

import math
from typing import Any

from rig.sweep.points import Point
from rig.sweep.spec import SweepSpec

__all__ = ["B_M", "b_m_edges", "servo_edge"]

#: the varied parameter the edge is a value of
B_M = "emulator.params.b_m"


def servo_edge(cfg: Any) -> float | None:
    """The plant b_m [rad/(V s^2)] at which ``cfg``'s (7.30) becomes unstable in its linear mode
    (the least above the plant's own that is: ``gain_edge``); None where ``cfg`` is no such run
    (module docstring), inf where it stays stable up to 16 times the plant's.

    Parameters
    ----------
    cfg : Any
        A point's configuration.

    Returns
    -------
    float | None
        [rad/(V s^2)] the edge b_m; None: no such run; inf: stable up to 16 times.
    """
    from controllers.servo_loop import ServoPlant, gain_edge
    from plant_emulator.preset_params import DcServoPreset
    from rig.laws import make_law

    c, physics = cfg.controller, cfg.physics
    if c.kind != "position-servo" or not isinstance(physics, DcServoPreset) or not c.commands:
        return None
    axis = cfg.axis(c.commands[0])
    if axis.mode != "voltage":
        return None
    period = cfg.period
    law: Any = make_law(c.kind, c.params, period=period, reference=lambda t: (0.0, 0.0))
    if law.params.law != "7.30":
        return None
    delay = period if axis.sync_rpdo else axis.latency
    plant = ServoPlant(physics.a_m, physics.b_m, physics.tau_e, delay)
    return gain_edge(law.servo.params.design, law.params.h, plant) * physics.b_m


def b_m_edges(spec: SweepSpec, rows: list[dict[str, Any]]) -> dict[tuple[tuple[str, Any], ...], float]:
    """For each combination of the other varied parameters' values among ``rows``, the edge b_m
    (``servo_edge``) of the base with those values; {} where the study does not vary b_m, is a
    scenario's, or its base is no such run.

    Parameters
    ----------
    spec : SweepSpec
        The study.
    rows : list[dict[str, Any]]
        Its rows.

    Returns
    -------
    dict[tuple[tuple[str, Any], ...], float]
        The other parameters' values -> the edge b_m.
    """
    from rig.sweep.point import point_config, read_base

    if spec.scenario or B_M not in {p.name for p in spec.parameters}:
        return {}
    base = read_base(spec)
    others = [p.name for p in spec.parameters if p.name != B_M]
    edges: dict[tuple[tuple[str, Any], ...], float] = {}
    for row in rows:
        key = tuple((name, row.get(name)) for name in others)
        if key in edges:
            continue
        values = dict(key) | {B_M: row[B_M]}
        edge = servo_edge(point_config(spec, base, Point(0, values, spec.noise_seed)))
        if edge is None:
            return {}
        edges[key] = edge
    return {k: v for k, v in edges.items() if math.isfinite(v)}
