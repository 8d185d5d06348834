"""The rules between the tables of a rig configuration, checked once when it is loaded.

Each key's own range is data of its field (``drivers.schema``); the ``[controller]`` table's
rules with the axes are ``rig.config.controller``'s. Here, what needs the whole file: a period
the run can have (``[run] period``, or the emulator preset's); a SYNC from another device in
real time only; node ids and axis names that are unique and not the host's (the axes of one
drive of several, each its own ``axis`` on one node id, are one device); the answer budget
inside the period; a ``[run] period`` the emulated devices can take; the emulated inverters'
communication-loss time longer than the period; faults of the emulated bus only with an
emulated bus; a profile for a profile reference.
Each refusal is one ``ConfigError`` naming the file, the table, the key and the value.
"""

from __future__ import annotations

from typing import Any

from drivers.errors import ConfigError
from drivers.schema import keys

__all__ = ["check_rig"]


def check_rig(cfg: Any) -> None:
    """Every rule between the tables of ``cfg`` (a ``RigConfig``); ConfigError at the first broken.

    Parameters
    ----------
    cfg : Any
        The ``RigConfig``.

    Raises
    ------
    ConfigError
        At the first broken rule.
    """
    src, b = cfg.source, cfg.bus
    if b.sync == "external" and cfg.run.time != "realtime":
        raise ConfigError(
            f'{src}: [bus] sync = "external" needs [run] time = "realtime" (lock-step is the host\'s SYNC)'
        )
    names = [a.name for a in cfg.axes]
    for name in names:
        if names.count(name) > 1:
            raise ConfigError(f"{src}: two [[axis]] tables are named {name!r}")
    nodes = [a.node_id for a in cfg.axes if a.kind != "modbus"]
    places = [(a.node_id, a.axis if a.kind == "cia402" else 0) for a in cfg.axes if a.kind != "modbus"]
    for node, axis in places:
        if places.count((node, axis)) > 1 and axis:
            raise ConfigError(f"{src}: two [[axis]] tables are axis {axis} of node_id {node}")
        if places.count((node, axis)) > 1 or (not axis and nodes.count(node) > 1):
            raise ConfigError(f"{src}: two CANopen axes have node_id {node}")
    if b.host_node in nodes:
        raise ConfigError(f"{src}: [bus] host_node = {b.host_node} is also an axis's node_id")
    _period(cfg)
    if cfg.reference.kind == "profile" and not cfg.reference.profile:
        raise ConfigError(f'{src}: [reference] kind = "profile" needs profile (a time profile)')
    _faults(cfg)


def _period(cfg: Any) -> None:
    """A period to run at; the answer budget and the emulated inverters' comm-loss time around it."""
    src, period = cfg.source, cfg.period
    if not period > 0.0:
        raise ConfigError(
            f"{src}: [run] period must be set (> 0 s): no [emulator] preset or device gives one"
        )
    budget = cfg.run.answer_budget
    if not budget < period:
        raise ConfigError(
            f"{src}: [run] answer_budget = {budget!r}: must be shorter than the period {period:g} s"
        )
    _emulated_period(cfg)
    if any(a.kind == "modbus" for a in cfg.axes):
        from plant_emulator.inverter_model import InverterModel

        timeout = cfg.emulator.inverter.get(
            "comm_loss_timeout", keys(InverterModel)["comm_loss_timeout"].default
        )
        if not period < timeout:  # the host polls once a period, on either clock
            raise ConfigError(
                f"{src}: [run] period {period:g} s is not shorter than the emulated inverter's "
                f"comm_loss_timeout {timeout:g} s: it would trip between two cycles "
                "(raise [emulator.inverter] comm_loss_timeout)"
            )


def _emulated_period(cfg: Any) -> None:
    """``[run] period`` is the emulated devices' period too (``RigConfig.physics``): refused where
    ``[emulator.params]`` gives another, or where the preset's period is not a key of its own
    (grid-converter's is ratio/f_line)."""
    physics, period = cfg.emulator.physics, cfg.run.period
    if physics is None or not period > 0.0 or abs(physics.period - period) <= 1e-9 * period:
        return
    e = cfg.emulator
    what = f"device {e.device}" if e.device else f"preset {e.preset}"
    head = f"{cfg.source}: [run] period = {period:g} s, but the emulated devices run at {physics.period:g} s"
    if "period" not in keys(type(physics)):
        raise ConfigError(
            f"{head} (ratio/f_line of {what}): leave [run] period out and set the period through "
            "[emulator.params] ratio and f_line"
        )
    if "period" in e.params:
        raise ConfigError(
            f"{head} ([emulator.params] period of {what}): give the period once, in [run] or in "
            "[emulator.params]"
        )


def _faults(cfg: Any) -> None:
    """Faults of the emulated CAN bus need an emulated CANopen device to act on."""
    f, default = cfg.faults, type(cfg.faults)()
    if f == default:  # none given: a run on a real bus loads no emulator
        return
    from plant_emulator.faults import FAULT_NAMES

    given = [k for k in FAULT_NAMES if k != "seed" and getattr(f, k) != getattr(default, k)]
    if given and cfg.emulator.physics is None:
        raise ConfigError(
            f"{cfg.source}: [faults] {', '.join(given)}: faults of the CAN bus are the emulator's: "
            "they need a CANopen [emulator] preset or device"
        )
