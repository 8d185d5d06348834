"""Fault injection on the emulated bus and devices, per run.

``FaultPlan`` says what goes wrong and when (seconds of emulated time);
``FaultInjector`` makes it happen on a ``SyncHub``: it drops frames (a random
fraction, or a device's TPDOs or heartbeats from a given time on) and, at the
SYNC at or after a given time, resets the drive node, raises an over-current
fault (EMCY 0x2310) or makes the encoder jump. Deterministic: the frame loss
uses its own seeded generator, so a lock-step run with faults repeats exactly.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, fields
from typing import Any

import can

from drivers.maps.cia import COB_HEARTBEAT, COB_SYNC, COB_TPDO, EmcyCode
from plant_emulator.lockstep import SyncHub

__all__ = ["FAULT_NAMES", "FaultInjector", "FaultPlan", "parse_faults"]


@dataclass(frozen=True)
class FaultPlan:
    """What to inject; times in seconds of emulated time (inf: never).

    Raises
    ------
    ValueError
        If ``frame_loss`` is not in [0, 1) or a time is < 0.
    """

    frame_loss: float = 0.0  #: fraction of frames lost on the wire from the first SYNC on, in [0, 1)
    seed: int = 0  #: of the frame-loss generator
    tpdo_stall_at: float = math.inf  #: the drive's TPDOs stop
    heartbeat_loss_at: float = math.inf  #: the drive's heartbeats stop
    node_reset_at: float = math.inf  #: the drive resets itself (power glitch): boot-up, PRE-OPERATIONAL
    overcurrent_at: float = math.inf  #: the drive trips over-current (EMCY 0x2310)
    encoder_glitch_at: float = math.inf  #: the position jumps by ``encoder_glitch_counts``
    encoder_glitch_counts: int = 2048  #: the jump [counts]

    def __post_init__(self) -> None:
        if not 0.0 <= self.frame_loss < 1.0:
            raise ValueError(f"frame_loss must be in [0, 1), got {self.frame_loss!r}")
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name.endswith("_at") and not (value >= 0.0):
                raise ValueError(f"{f.name} must be a time >= 0 s, got {value!r}")

    @property
    def active(self) -> bool:
        return any(getattr(self, f.name) != f.default for f in fields(self) if f.name != "seed")


FAULT_NAMES = tuple(f.name for f in fields(FaultPlan))


def parse_faults(items: dict[str, str] | list[str], source: str = "--fault") -> FaultPlan:
    """A plan from ``NAME=VALUE`` pairs; a ValueError names the bad item and where it came from.

    Parameters
    ----------
    items : dict[str, str] | list[str]
        ``NAME=VALUE`` pairs, or a mapping.
    source : str, optional
        Where they came from, named in the error.

    Returns
    -------
    FaultPlan
        The plan.

    Raises
    ------
    ValueError
        If a name is unknown or a value is not a number or not allowed.
    """
    pairs = items.items() if isinstance(items, dict) else (item.partition("=")[::2] for item in items)
    kinds = {f.name: f.type for f in fields(FaultPlan)}
    values: dict[str, Any] = {}
    for given, text in pairs:
        name = given.strip()
        if name not in kinds:
            raise ValueError(f"{source}: unknown fault {name!r}; known: {', '.join(FAULT_NAMES)}")
        try:
            values[name] = int(text) if kinds[name] == "int" else float(text)
        except (TypeError, ValueError):
            raise ValueError(f"{source}: {name}={text!r} is not a number") from None
    try:
        return FaultPlan(**values)
    except ValueError as exc:
        raise ValueError(f"{source}: {exc}") from exc


class FaultInjector:
    """Apply ``plan`` to ``hub``, whose drive device is ``drive`` (an ``EmulatedDrive``).

    Parameters
    ----------
    plan : FaultPlan
        What to inject.
    hub : SyncHub
        The SYNC hub of the emulated world.
    drive : Any
        The drive device (an ``EmulatedDrive``).
    """

    def __init__(self, plan: FaultPlan, hub: SyncHub, drive: Any) -> None:
        self.plan = plan
        self.hub = hub
        self.drive = drive
        self.rng = random.Random(plan.seed)
        self.dropped = 0
        self._done: set[str] = set()
        hub.drop = self._drop
        self._bus = hub.bus(queue=False, channel="faults")
        self._bus.listeners.append(self._on_frame)

    def _drop(self, msg: can.Message) -> bool:
        p, t, node = self.plan, self.hub.clock, self.drive.node_id
        cob = msg.arbitration_id
        lose = p.frame_loss > 0.0 and t > 0.0 and self.rng.random() < p.frame_loss  # from the first SYNC on
        lose = lose or (t >= p.tpdo_stall_at and cob - node in COB_TPDO)
        lose = lose or (t >= p.heartbeat_loss_at and cob == COB_HEARTBEAT + node)
        if lose:
            self.dropped += 1
        return lose

    def _once(self, name: str, at: float) -> bool:
        if self.hub.clock >= at and name not in self._done:
            self._done.add(name)
            return True
        return False

    def _on_frame(self, msg: can.Message) -> None:
        if msg.arbitration_id != COB_SYNC:  # act at SYNC: the device has just latched this cycle
            return
        p, drive = self.plan, self.drive
        if self._once("node_reset", p.node_reset_at):
            drive.reset()
        if self._once("overcurrent", p.overcurrent_at):
            drive.raise_fault(EmcyCode.OVER_CURRENT)
        if self._once("encoder_glitch", p.encoder_glitch_at):
            drive.glitch_counts += p.encoder_glitch_counts

    def shutdown(self) -> None:
        """Stop injecting (the session closes it with its buses)."""
        self.hub.drop = None
        self._bus.shutdown()
