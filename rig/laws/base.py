"""The contract of a control law run by the host loop.

A law is built once from its typed parameters (``Params``, a frozen dataclass),
the loop period and the reference, and is never changed afterwards. Each cycle
``step(t, feedback)`` gets the ``Feedback`` of the axes it reads (in the order
``[controller] reads`` names them) and returns a ``LawStep``: one command per
axis it commands (in the order of ``[controller] commands``), the reference and
the measured value of the controlled variable, and its internals (the columns
``internals`` names). A sliding-mode law names ``SIGN_LAW`` among them: 1 for a cycle whose
command came from outside its linear region (the sign term of (6.8), (7.30b)'s sigma branch, a
bound that acts), else 0; the run's ``sign_law_share`` is its mean (docs/chattering.md).
Before the first step, ``begin(feedback)`` gets the first samples:
a law whose reference is a position (``position_reference``) puts the reference's zero
where the read axis stands (``[reference] origin = "start"``, the default: a move by
``distance`` from there), or keeps it absolute (``origin = "zero"``, after homing).
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from drivers.base import Feedback

__all__ = ["SIGN_LAW", "Law", "LawParams", "LawStep", "Reference"]

#: reference(t) -> (value, rate) at time t [s]
Reference = Callable[[float], tuple[float, float]]

#: the internal column of a sliding-mode law: 1.0 where the cycle was outside its linear region
SIGN_LAW = "sign_law"


@dataclass(frozen=True, slots=True)
class LawStep:
    """What a law gives each cycle."""

    commands: tuple[float | complex, ...]  #: one per commanded axis, in the unit of its mode
    reference: float  #: of the controlled variable
    measurement: float  #: the controlled variable as measured
    internals: tuple[float, ...] = ()  #: in the order of ``Law.internals``


class LawParams:
    """Base of a law's ``Params``: a frozen dataclass whose fields are the ``[controller]`` keys
    (``drivers.schema.key``: type, unit, range, meaning), checked when the file is loaded."""

    def rules(self, period: float) -> None:
        """The rules between the keys, and with the run's ``period`` [s]: ``drivers.schema.Refused``
        (or ValueError) when one is broken; called once, when the configuration is loaded.

        Parameters
        ----------
        period : float
            [s] the run's.
        """


class Law(abc.ABC):
    """Base of the laws of ``rig.laws.LAWS``.

    Parameters
    ----------
    params : Any
        The law's parameters (its ``Params``).
    period : float
        [s] the loop's.
    reference : Reference
        The reference.
    """

    #: the typed parameter dataclass (a ``LawParams``); the loop period is ``period``, not a key
    Params: ClassVar[type[LawParams]]
    #: for each commanded axis, the modes its command may be in
    modes: ClassVar[tuple[frozenset[str], ...]]
    #: how many axes the law reads
    reads: ClassVar[int] = 1
    #: names of the internal columns the recorder keeps
    internals: ClassVar[tuple[str, ...]] = ()
    #: the reference is a position [rad] of the read axis (``begin`` may move its zero)
    position_reference: ClassVar[bool] = False
    #: the unit of the reference, the measurement and so of the error (summary and columns)
    error_unit: ClassVar[str] = "rad/s"
    #: "start": a position reference is relative to the first sample; "zero": absolute
    origin: str = "start"
    #: the position [rad] added to a position reference (set by ``begin``)
    offset: float = 0.0

    def __init__(self, params: Any, *, period: float, reference: Reference) -> None:
        self.params = params
        self.period = period  #: [s]
        self.reference = reference

    def begin(self, feedback: Sequence[Feedback]) -> None:
        """Called once with the first samples, before the first ``step``.

        Parameters
        ----------
        feedback : Sequence[Feedback]
            The first sample of each axis.
        """
        if self.position_reference and self.origin == "start":
            offset = self.offset = feedback[0].position
            if offset != 0.0:
                reference = self.reference
                self.reference = lambda t: _shifted(reference(t), offset)

    def held(self, commands: Sequence[complex | float]) -> None:
        """A cycle without a new sample sent ``commands`` instead of a step's (``[run]
        missed_sample = "zero"``): the drives hold them until the law's next step. A law with a
        model of the plant takes them as what was applied; the default does nothing.

        Parameters
        ----------
        commands : Sequence[complex | float]
            What each commanded axis was sent, in the law's order.
        """
        return

    def sensitivity(self) -> tuple[float, float]:
        """(|du/dtheta| [unit of u per rad], |du/domega| [unit of u per rad/s]): how far the first
        command moves per unit of the first read axis's position and speed, the gradient of the
        law's continuous part in linear operation (a relay's switching is not part of it: it is
        the chattering to be counted). With the axis's quanta it gives the chattering threshold
        (``rig.report.metrics.count_threshold``). The default (0, 0): not stated, every alternation above
        rounding counts.

        Returns
        -------
        tuple[float, float]
            (|du/dtheta|, |du/domega|).
        """
        return (0.0, 0.0)

    @abc.abstractmethod
    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        """One cycle at time ``t`` [s]; must not do I/O.

        Parameters
        ----------
        t : float
            [s] the cycle's time.
        feedback : Sequence[Feedback]
            Each axis's sample.

        Returns
        -------
        LawStep
            The commands and what to record.

        Raises
        ------
        SafetyStop
            Where the law stops the run (a replay or excitation gone wrong).
        """


def _shifted(value: tuple[float, float], offset: float) -> tuple[float, float]:
    return value[0] + offset, value[1]
