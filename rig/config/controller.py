"""The ``[controller]`` table: the law, the axes it reads and commands, its parameters, a design file.

``controller_config(path, table, axes, period)`` checks it when the file is loaded: ``kind``
names a law of ``rig.laws.LAWS``; ``reads`` and ``commands`` name axes, as many as the law
reads and commands, each commanded axis in a mode the law commands (with one axis that has a
mode, both may be left out); the parameters are keys of the law's ``Params``
(``drivers.schema.key``: type, range) and keep its rules at the run's ``period`` (its
``rules(period)``); ``design = "FILE"`` gives a_m, b_m (and lam, or a ``rig tune`` design's
parameters). The law is built from what this returns without another check.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from drivers.schema import Refused
from rig.config.axes import AxisConfig
from rig.config.model import Model, read_model
from rig.config.params import required, typed_values

__all__ = ["controller_config"]


def controller_config(path: str, table: dict[str, Any], axes: tuple[AxisConfig, ...], period: float) -> Any:
    """The checked ``ControllerConfig`` of ``table`` in file ``path`` (see the module docstring).

    Parameters
    ----------
    path : str
        The file, named in errors.
    table : dict[str, Any]
        ``[controller]``.
    axes : tuple[AxisConfig, ...]
        The rig's axes.
    period : float
        [s] ``[run] period``.

    Returns
    -------
    Any
        The ``ControllerConfig``.

    Raises
    ------
    ConfigError
        If a key is unknown, of a wrong type or refused.
    """
    from rig.config.schema import ControllerConfig
    from rig.laws import law_class

    table = dict(table)
    kind = table.pop("kind", None)
    if not isinstance(kind, str):
        raise ConfigError(f"{path}: [controller] needs kind (a string naming the law)")
    cls = law_class(kind, path)
    roles = _roles(path, table, axes)
    model = _design(path, table, kind) if "design" in table else None
    where = f"{path}: [controller] {kind}"
    params = typed_values(cls.Params, table, where)
    required(cls.Params, params, where)
    if period > 0.0:
        try:
            cls.Params(**params).rules(period)
        except Refused as exc:
            raise ConfigError(f"{where} {exc}") from None
    _check_axes(path, kind, cls, roles, axes)
    if model is not None:
        _check_design(path, model, [a for a in axes if a.name in roles["commands"]], period)
    return ControllerConfig(kind, roles["reads"], roles["commands"], params, model)


def _roles(path: str, table: dict[str, Any], axes: tuple[AxisConfig, ...]) -> dict[str, tuple[str, ...]]:
    """``reads`` and ``commands``: lists of axis names; a law over one axis needs no names (with one
    commandable axis, it reads and commands that one)."""
    roles: dict[str, tuple[str, ...]] = {}
    for key in ("reads", "commands"):
        value = table.pop(key, [])
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{path}: [controller] {key} = {value!r}: expected a list of axis names")
        roles[key] = tuple(value)
    if not roles["commands"]:
        commandable = [a.name for a in axes if a.mode and not a.profile]
        if len(commandable) != 1:
            raise ConfigError(
                f"{path}: [controller] commands is missing: name the axes the law commands "
                f"(of {', '.join(commandable) or 'none'})"
            )
        roles["commands"] = (commandable[0],)
    roles["reads"] = roles["reads"] or roles["commands"]
    return roles


def _check_axes(
    path: str, kind: str, cls: Any, roles: dict[str, tuple[str, ...]], axes: tuple[AxisConfig, ...]
) -> None:
    """The axes named exist, the commanded ones can be commanded, in a mode the law commands."""
    by_name = {a.name: a for a in axes}
    for key in ("reads", "commands"):
        for name in roles[key]:
            if name not in by_name:
                raise ConfigError(
                    f"{path}: [controller] {key} names {name!r}; the axes are {', '.join(by_name)}"
                )
    for name in roles["commands"]:
        a = by_name[name]
        if not a.mode or a.profile:
            raise ConfigError(
                f"{path}: [controller] commands {name!r}, which has "
                + ("a profile" if a.profile else "no mode (a feedback-only axis)")
            )
    reads, commands = roles["reads"], roles["commands"]
    if len(reads) != cls.reads or len(commands) != len(cls.modes):
        raise ConfigError(
            f"{path}: [controller] {kind} reads {cls.reads} and commands {len(cls.modes)} "
            f"axis(es); reads = {list(reads)}, commands = {list(commands)}"
        )
    for name, modes in zip(commands, cls.modes):
        mode = by_name[name].mode
        if mode not in modes:
            raise ConfigError(
                f"{path}: [controller] {kind} commands {' or '.join(sorted(modes))}, "
                f"but axis {name!r} is in mode {mode!r}"
            )


def _check_design(path: str, model: Model, commanded: list[AxisConfig], period: float) -> None:
    """The model's input is what the commanded axes take (voltage mode, or CST for a torque); a
    design (it has lam) was made for the run's period."""
    where = f"{path}: [controller] design ({model.source})"
    mode = "cst" if model.input == "torque" else "voltage"
    for a in commanded:
        if a.mode != mode:
            raise ConfigError(
                f"{where}: its input is a {model.input}, so axis {a.name!r} must be in mode = {mode!r}, "
                f"not {a.mode!r}"
            )
    designed = model.lam is not None or model.law is not None
    if designed and period > 0.0 and abs(model.dt - period) > 1e-9 * period:
        raise ConfigError(
            f"{where}: designed for T = {model.dt:g} s, but [run] period = {period:g} s: design it again "
            "with --period"
        )


def _design(path: str, table: dict[str, Any], kind: str) -> Model:
    """``design = "FILE"`` (a path relative to the configuration's folder): its a_m, b_m and,
    from a design file, lam go into ``table`` (from a ``rig tune`` file, its params, for the
    kind it names); a key also given in ``table`` is an error."""
    design = table.pop("design")
    where = f"{path}: [controller] design = {design!r}"
    if not isinstance(design, str) or not design:
        raise ConfigError(
            f"{where}: expected the path of rig identify's identification.json (or its run "
            "directory) or of rig design dtsm --json's output"
        )
    file = Path(design) if Path(design).is_absolute() else Path(path).parent / design
    model = read_model(file, where=where)
    if model.law is not None and model.law != kind:
        raise ConfigError(f"{where}: designed for kind = {model.law!r}, not {kind!r} (rig tune {kind} ...)")
    given = (
        dict(model.params or {})
        if model.law is not None
        else {"a_m": model.a_m, "b_m": model.b_m, **({} if model.lam is None else {"lam": model.lam})}
    )
    both = sorted(set(given) & set(table))
    if both:
        raise ConfigError(f"{where}: {', '.join(both)} also given in [controller]: give each once")
    table.update(given)
    return model
