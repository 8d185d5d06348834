"""What a run controls: the law of ``[controller]`` and which axes it reads and commands.

``build_law`` makes the law (``rig.laws.make_law``) with its reference and the injected faults of
``[faults]``; ``Wiring`` says which of the run's axes (indices, in configuration order) the law
reads and commands, and which follow a time profile instead (``drivers.profiles``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from drivers.profiles import parse_profile
from rig.config import RigConfig
from rig.host.injected import with_injected_faults
from rig.host.references import reference_of
from rig.laws import Law, make_law

__all__ = ["Wiring", "build_law", "wiring_of"]


@dataclass(frozen=True)
class Wiring:
    """Which axes (indices into the loop's axes) the law reads and commands, and the profile axes."""

    #: the axes the law reads
    reads: tuple[int, ...]
    #: the axes the law commands
    commands: tuple[int, ...]
    #: (axis, its time profile: t [s] -> command) of the axes following a profile
    profiles: tuple[tuple[int, Callable[[float], float]], ...] = ()
    #: the law's axes, then the profile axes: the order of a cycle's commands
    commanded: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "commanded", self.commands + tuple(i for i, _ in self.profiles))


def wiring_of(cfg: RigConfig) -> Wiring:
    """The wiring of ``[controller] reads``, ``commands`` and the axes' ``profile``.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.

    Returns
    -------
    Wiring
        The axes' indices, in configuration order.
    """
    names = [a.name for a in cfg.axes]
    return Wiring(
        tuple(names.index(n) for n in cfg.controller.reads),
        tuple(names.index(n) for n in cfg.controller.commands),
        tuple((names.index(a.name), parse_profile(a.profile)) for a in cfg.axes if a.profile),
    )


def build_law(cfg: RigConfig, period: float) -> Law:
    """The law of ``[controller]``, with its reference and ``[faults]``' injected faults.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration (the law checked with its axes when it was loaded).
    period : float
        The loop's period [s].

    Returns
    -------
    Law
        The law.
    """
    c = cfg.controller
    law = make_law(
        c.kind, c.params, period=period, reference=reference_of(cfg.reference), origin=cfg.reference.origin
    )
    return with_injected_faults(law, cfg.faults)
