"""Another producer on a COB-ID of the host's nodes: frames on a TPDO's COB-ID its node cannot
have sent, and a sample whose position contradicts the drive's own speed.

A COB-ID has one producer (CiA 301 7.2.2): a TPDO is its node's. Beside ``drivers.master_watch``
(another master: the frames only a master sends), ``ProducerWatch`` counts, on the host's canopen
``Network``, the SYNCs on the bus and the frames on each TPDO COB-ID the host receives
(``TpdoSlot``, from the slot's making on, the mapping in force):

- a frame of another length than the mapping in force is not its node's (CiA 301: such a PDO is
  not processed);
- a TPDO of transmission type 1 answers each SYNC once, one of type 0 (acyclic synchronous) at
  most once, one of type n = 2-240 every n-th SYNC (from a start the host does not know: at most
  SYNCs // n + 1 frames): more frames than that are more answers than SYNCs. The count is of all
  SYNCs and all frames since the slot was made, so a drive's burst of answers after a stall (the
  SYNCs it owed) is no surplus; a SYNC the node never answered leaves room for one frame more.
  Event-driven TPDOs (254, 255) have no such bound.

The SYNCs counted are the ones the host sends through the network (its ``send_message`` is
wrapped, as ``MasterWatch`` wraps it) and the ones heard: another device's, the kernel broadcast
manager's (sent through its own socket, heard on the host's), or a second producer's (named by
the master watch; the answers to it are the node's own). On a bus that gives the host its own
frames back (``echoes()``: ``MasterWatch.echoes``) a SYNC heard while the host's own are still to
come back is its echo, not counted twice.

What is found (``found``: COB-ID -> ``Finding``) is kept with the SYNC count at the time; from then
on that COB-ID's frames are not taken (two producers' frames carry nothing the host can trust:
a stop reads the node's state by SDO), and the axis's supervision raises ``OtherProducer`` naming
the COB-ID and the node.

``travel_band`` is the second rule's measure (the axis's ``foreign_sample``): the travel between
two consecutive samples that the drive's own speeds at both (0x606C) allow, with the resolution
and the acceleration the drive declares (0x60C5/0x60C6: without it, no such rule).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from drivers.errors import SafetyStop
from drivers.maps.cia import COB_SYNC, PDO_SYNC_MAX

__all__ = [
    "ACCELERATION_LIMITS",
    "Finding",
    "OtherProducer",
    "ProducerWatch",
    "declared_acceleration",
    "travel_band",
]

log = logging.getLogger(__name__)

#: the drive's max acceleration and deceleration (CiA 402) [velocity units/s]
ACCELERATION_LIMITS = (0x60C5, 0x60C6)


class TpdoSlot(Protocol):
    """What the watch needs of ``drivers.canopen_axis.TpdoSlot`` (which imports this module)."""

    node_id: int
    cob_id: int
    codec: Any  #: its struct (``size``: the mapping's bytes)
    ttype: int
    producers: ProducerWatch | None
    frames: int
    since: int


class OtherProducer(SafetyStop):
    """Another producer on a COB-ID of one of the host's nodes, found while running: a stop."""


@dataclass(frozen=True)
class Finding:
    """Another producer on ``cob_id`` of node ``node_id``, in words; ``syncs``: the SYNC count then."""

    cob_id: int  #: the COB-ID with two producers
    node_id: int  #: the node whose TPDO it is
    text: str  #: what was found, in words
    syncs: int  #: the SYNC count when it was found


def travel_band(
    v1: float, v2: float, dt_lo: float, dt_hi: float, *, resolution: tuple[float, float], accel: float
) -> tuple[float, float] | None:
    """[rad] the least and the most travel from one sample to the next that a drive reporting the
    speeds ``v1`` then ``v2`` [rad/s] (0x606C, latched with the positions) can have made in an
    elapsed time between ``dt_lo`` and ``dt_hi`` [s], its shaft accelerating by at most ``accel``
    [rad/s^2] (what the drive declares, 0x60C5/0x60C6); None where ``accel`` is not known (not
    finite, not > 0): then only the speed limit bounds the travel (the host's position-step check).

    The speed between the samples is not bounded by the two: it may reverse or peak inside the
    period (a chattering or stick-slip shaft at zero speed at both samples). With the elapsed time
    known (``dt_lo == dt_hi``: lock-step) the speed lies under min(v1 + a t, v2 + a (dt - t)) and
    over its mirror, and the travel between their integrals; else (receive times) only the start's
    and the end's envelopes hold, from either sample, over 0 to ``dt_hi``. Widened by one position
    count (``resolution[0]`` [rad]) for each of the two positions and one speed unit
    (``resolution[1]`` [rad/s]) on each speed (each is rounded, by half a unit).

    Parameters
    ----------
    v1, v2 : float
        [rad/s] the drive's speeds at the two samples.
    dt_lo, dt_hi : float
        [s] the least and the most time between them.
    resolution : tuple[float, float]
        (one position count [rad], one speed unit [rad/s]).
    accel : float
        [rad/s^2] the most the shaft accelerates (inf: no bound).

    Returns
    -------
    tuple[float, float] | None
        (least, most) travel [rad]; None where ``accel`` is not a finite value > 0 (no rule).
    """
    if not (math.isfinite(accel) and accel > 0.0):
        return None
    q_position, q_speed = resolution
    slack = 2.0 * q_position
    if dt_lo == dt_hi:
        most = _under(v1 + q_speed, v2 + q_speed, dt_hi, accel)
        least = -_under(-v1 + q_speed, -v2 + q_speed, dt_hi, accel)
    else:
        most = min(_ahead(v1 + q_speed, dt_hi, accel), _ahead(v2 + q_speed, dt_hi, accel))
        least = -min(_ahead(-v1 + q_speed, dt_hi, accel), _ahead(-v2 + q_speed, dt_hi, accel))
    return least - slack, most + slack


def declared_acceleration(values: list[Any], per: float) -> float:
    """[rad/s^2] the largest of the acceleration objects ``values`` read from a drive (None: it has
    not got that one) in velocity units per s, ``per`` of them per rad/s^2; inf where none is
    there, or one says 'no limit' (0, or 0xFFFFFFFF: EPOS4's 0x60C5).

    Parameters
    ----------
    values : list[Any]
        The acceleration objects read (None: the drive has not got that one).
    per : float
        Velocity units per s per rad/s^2.

    Returns
    -------
    float
        [rad/s^2] the largest; inf where none, or one says "no limit" (0, 0xFFFFFFFF).
    """
    given = [v for v in values if v is not None]
    if not given or not all(isinstance(v, int) and 0 < v < 0xFFFF_FFFF for v in given):
        return math.inf
    return max(given) / per if math.isfinite(per) and per > 0.0 else math.inf


def _under(v1: float, v2: float, dt: float, a: float) -> float:
    """[rad] the integral over ``dt`` of min(v1 + a t, v2 + a (dt - t)): the most a shaft leaving
    at ``v1`` and arriving at ``v2`` [rad/s] travels in ``dt`` [s] at |dv/dt| <= ``a``."""
    a = max(a, abs(v2 - v1) / dt) if dt > 0.0 else a  # the samples' own change is possible
    t = min(max((v2 - v1 + a * dt) / (2.0 * a), 0.0), dt)  # where the two lines meet
    return v1 * t + 0.5 * a * t * t + v2 * (dt - t) + 0.5 * a * (dt - t) ** 2


def _ahead(v: float, dt: float, a: float) -> float:
    """[rad] the integral over ``dt`` of max(0, v + a t): the most a shaft at ``v`` [rad/s] at one
    end travels forward within any time up to ``dt`` [s] at |dv/dt| <= ``a``."""
    if v >= 0.0:
        return v * dt + 0.5 * a * dt * dt
    rest = dt + v / a  # the time left once it has come to rest
    return 0.5 * a * rest * rest if rest > 0.0 else 0.0


class ProducerWatch:
    """See the module docstring; ``echoes()``: the bus gives the host its own frames back.

    Parameters
    ----------
    network : Any
        The host's canopen ``Network``.
    echoes : Callable[[], bool], optional
        Whether the bus gives the host its own frames back.
    """

    def __init__(self, network: Any, *, echoes: Callable[[], bool] = lambda: False) -> None:
        self.network = network
        self.echoes = echoes
        self.syncs = 0  #: SYNCs on the bus since the watch began (sent and heard)
        self._own = 0  #: the host's own SYNCs not heard back (their echo, on a bus that echoes)
        #: COB-ID -> the first finding on it (the per-cycle test is ``alarm``)
        self.found: dict[int, Finding] = {}
        self.alarm = False
        self._lock = threading.Lock()
        self._own_attr = "send_message" in vars(network)  #: another wrapper was there (MasterWatch's)
        self._send = network.send_message
        network.send_message = self._sending
        network.subscribe(COB_SYNC, self._on_sync)

    def _sending(self, can_id: int, data: bytes, remote: bool = False) -> None:
        """The network's ``send_message``, counting the SYNCs it sends (before it sends them: an
        answer comes after its SYNC)."""
        if can_id == COB_SYNC:
            self.syncs += 1
            self._own += 1
        self._send(can_id, data, remote)

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if self._own and self.echoes():
            self._own -= 1  # the host's own SYNC given back by its adapter
            return
        self.syncs += 1

    def watch(self, slot: TpdoSlot) -> None:
        """Count ``slot``'s frames from now on against the SYNCs from now on.

        Parameters
        ----------
        slot : TpdoSlot
            A TPDO's receive slot.
        """
        slot.producers = self
        slot.frames = 0
        slot.since = self.syncs

    def take(self, slot: TpdoSlot, data: bytes | bytearray) -> bool:
        """A frame on ``slot``'s COB-ID (its receive path): False where it is not its node's (found,
        or its COB-ID found before).

        Parameters
        ----------
        slot : TpdoSlot
            The TPDO's receive slot.
        data : bytes | bytearray
            The frame's data.

        Returns
        -------
        bool
            True where the frame may be its node's.
        """
        if slot.cob_id in self.found:
            return False
        size = slot.codec.size
        if len(data) != size:
            self._found(slot, f"a frame of {len(data)} bytes where its mapping has {size}")
            return False
        slot.frames += 1
        ttype = slot.ttype
        if ttype <= PDO_SYNC_MAX:
            syncs = self.syncs - slot.since
            allowed = syncs if ttype <= 1 else syncs // ttype + 1
            if slot.frames > allowed:
                every = (
                    "once a SYNC" if ttype == 1 else f"once every {ttype} SYNCs" if ttype else "once at most"
                )
                self._found(
                    slot, f"{slot.frames} frames for {syncs} SYNCs, where type {ttype} answers {every}"
                )
                return False
        return True

    def _found(self, slot: TpdoSlot, what: str) -> None:
        node = slot.node_id
        text = (
            f"node {node}: another producer on COB-ID 0x{slot.cob_id:03X} (a TPDO of node {node}): {what}, "
            f"which node {node} did not send"
        )
        with self._lock:
            if slot.cob_id not in self.found:
                self.found[slot.cob_id] = Finding(slot.cob_id, node, text, self.syncs)
                self.alarm = True

    def intruder(self, node_id: int) -> str | None:
        """The first finding on a COB-ID of ``node_id``, in words (None: none).

        Parameters
        ----------
        node_id : int
            The node.

        Returns
        -------
        str | None
            The finding in words; None: none.
        """
        with self._lock:
            mine = [f for f in self.found.values() if f.node_id == node_id]
        return min(mine, key=lambda f: f.syncs).text if mine else None

    def cause(self, reason: str, mark: int) -> str:
        """The cause of a stop that a check of a sample made (``reason``) at the SYNC count
        ``mark``: where another producer was found by the answers to the next SYNC (the node's
        own answer came after a frame the cycle took for it), the stop's sample may have been
        that frame, and the stop is named for the other producer; else ``reason``.

        Parameters
        ----------
        reason : str
            The stop's reason, from a check of a sample.
        mark : int
            The SYNC count of that sample.

        Returns
        -------
        str
            ``reason``, with the other producer named where one was found then.
        """
        with self._lock:
            found = [f for f in self.found.values() if f.syncs <= mark + 1]
        if not found:
            return reason
        first = min(found, key=lambda f: f.syncs)
        log.warning("the safe stop's cause: %s", first.text)
        return f"{first.text}; the run had stopped on a sample it may have sent: {reason}"

    def close(self) -> None:
        """Stop counting SYNCs and give the network back its ``send_message``."""
        if COB_SYNC in self.network.subscribers and self._on_sync in self.network.subscribers[COB_SYNC]:
            self.network.unsubscribe(COB_SYNC, self._on_sync)
        if vars(self.network).get("send_message") == self._sending:
            if self._own_attr:
                self.network.send_message = self._send
            else:
                del self.network.send_message  # the network's own again
