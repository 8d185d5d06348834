"""The identification experiment's plan (``rig identify``): the rig it runs on (``Base``: a
configuration file's, a preset's or a zoo twin's in this process), the excitation, and the
experiment's configuration (``plan_experiment``), all checked before anything is opened.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from drivers.errors import ConfigError
from rig.config import RigConfig
from rig.config.params import parse_items
from rig.identify.request import DITHER, PlanError, Request, closed_loop, measures_response, resolved

__all__ = ["Base", "Plan", "excitation_of", "on_file", "on_preset", "on_twin", "plan_experiment"]


@dataclasses.dataclass(frozen=True)
class Base:
    """The rig an experiment runs on.

    Attributes
    ----------
    config : RigConfig
        Its configuration (the experiment replaces the law).
    period : float
        [s] its sample period.
    emulate : str | None
        The preset or twin emulated in this process (None: the configuration's bus).
    params : dict[str, Any] | None
        The preset's parameters (None: as the configuration gives them).
    """

    config: RigConfig
    period: float
    emulate: str | None = None
    params: dict[str, Any] | None = None


@dataclasses.dataclass(frozen=True)
class Plan:
    """An experiment ready to run (``rig.identify.experiment.run_experiment``).

    Attributes
    ----------
    request : Request
        What was asked for, every default filled in.
    config : RigConfig
        The experiment's configuration.
    emulate : bool
        It runs on an emulator in this process.
    """

    request: Request
    config: RigConfig
    emulate: bool


def on_file(path: str, param: Sequence[str]) -> Base:
    """The rig of a configuration file.

    Parameters
    ----------
    path : str
        The file.
    param : Sequence[str]
        ``--param`` items: none may be given (they set a preset's parameters).

    Returns
    -------
    Base
        Its rig.

    Raises
    ------
    PlanError
        If ``param`` is given, or the file has no period.
    """
    from rig.config import load_config

    if param:
        raise PlanError("--param sets a parameter of the --emulate preset")
    cfg = load_config(path)
    if cfg.run.period <= 0.0:
        raise PlanError(f"{path}: [run] period must be set")
    return Base(cfg, cfg.run.period)


def on_preset(name: str, param: Sequence[str], demo: RigConfig) -> Base:
    """A preset in this process, with ``demo``'s axis and limits (the paper's servo).

    Parameters
    ----------
    name : str
        The preset (``plant_emulator.presets.PRESETS``).
    param : Sequence[str]
        ``--param`` items over its values.
    demo : RigConfig
        The rig around it (``rig.papers.demo.demo_config``).

    Returns
    -------
    Base
        Its rig.
    """
    from rig.config.emulator import physics

    where = "rig identify: --param"
    params, built = physics(name, parse_items(param, where), f"rig identify: --emulate {name}", text=True)
    return Base(demo, float(built.period), name, params)


def on_twin(name: str, param: Sequence[str], input: str, demo: dict[str, Any]) -> Base:
    """A zoo twin in this process, in CST (a commercial drive has no voltage mode), with its own
    physics and units, ``param`` over the twin's values.

    Parameters
    ----------
    name : str
        The twin (``rig emulate --list``) or a profile file.
    param : Sequence[str]
        ``--param`` items over its values.
    input : str
        The experiment's input: "torque" only.
    demo : dict[str, Any]
        The rig document around it (``rig.papers.demo.demo_doc``).

    Returns
    -------
    Base
        Its rig.

    Raises
    ------
    PlanError
        If there is no such twin, or ``input`` is not a torque.
    """
    from plant_emulator.device_profile import device_profile
    from rig.config import rig_config
    from rig.config.emulator import preset_params

    try:
        profile = device_profile(name)
    except ConfigError as exc:
        raise PlanError(f"--emulate {name}: {exc} (a preset or a zoo twin: rig emulate --list)") from None
    if input != "torque":
        raise PlanError(
            f"--emulate {name}: a commercial drive's twin takes a torque (CST): give --input torque"
        )
    where = f"rig identify: --emulate {name}: --param"
    params = preset_params(profile.physics, parse_items(param, where), where, text=True, base=profile.params)
    doc = {**demo, "emulator": {"device": name, "params": params}}
    doc["axis"] = [{**demo["axis"][0], "mode": "cst"}, *demo["axis"][1:]]
    doc["controller"] = {"kind": "replay", "reads": ["motor"], "commands": ["motor"], "u": [0.0]}
    cfg = rig_config(doc, f"rig identify --emulate {name}")
    return Base(cfg, cfg.period, name)


def excitation_of(r: Request, period: float, *, closed: bool = False) -> tuple[Any, int, float]:
    """The experiment's input.

    Parameters
    ----------
    r : Request
        What was asked for, resolved (``rig.identify.request.resolved``).
    period : float
        [s] the sample period.
    closed : bool, optional
        The excitation r about 0 of the closed-loop experiment.

    Returns
    -------
    tuple[Any, int, float]
        (u per period as an np.ndarray, its period in samples or 0, the dither's standard deviation).

    Raises
    ------
    PlanError
        If the excitation cannot be made (the band does not fit the period).
    """
    from rig.identify.estimate import IdentificationError, excitation
    from rig.identify.frequency import period_samples, periodic_excitation

    assert r.amplitude is not None and r.clock is not None and r.duration is not None and r.u0 is not None
    if r.excitation == "friction":
        from rig.identify.friction import friction_excitation

        u = friction_excitation(
            amplitude=r.amplitude, clock=r.clock, dt=period, duration=r.duration, seed=r.seed
        )
        return u, 0, 0.0
    if not measures_response(r):
        try:
            u = excitation(
                str(r.excitation),
                dt=period,
                duration=r.duration,
                u0=r.u0,
                amplitude=r.amplitude,
                clock=r.clock,
                seed=r.seed,
            )
            return u, 0, 0.0
        except IdentificationError as exc:
            raise PlanError(str(exc)) from exc
    try:
        u = periodic_excitation(
            str(r.excitation),
            u0=0.0 if closed else r.u0,
            amplitude=r.amplitude,
            dt=period,
            duration=r.duration,
            f_min=r.f_min,
            f_max=r.f_max,
        )
    except IdentificationError as exc:
        raise PlanError(f"--f-min/--f-max: {exc}") from exc
    return u, period_samples(r.f_min, period), DITHER * r.amplitude


def plan_experiment(request: Request, base: Base) -> Plan:
    """The experiment ``request`` asks for on ``base``.

    Parameters
    ----------
    request : Request
        What was asked for.
    base : Base
        The rig it runs on (``on_file``, ``on_preset``, ``on_twin``).

    Returns
    -------
    Plan
        The experiment, ready to run.

    Raises
    ------
    PlanError
        If the PRBS clock is shorter than the period (and as ``resolved``, ``excitation_of`` and
        ``rig.identify.plan_loop`` raise it).
    """
    from rig.identify.experiment import experiment_config
    from rig.identify.plan_loop import loop_model, speed_loop_plan

    r = resolved(request)
    assert r.clock is not None
    if r.clock < base.period:
        raise PlanError(f"argument --clock: {r.clock:g} s is shorter than the period T = {base.period:g} s")
    closed = closed_loop(r)
    model = loop_model(r) if closed else None
    u, repeat, dither = excitation_of(r, base.period, closed=closed)
    cfg = experiment_config(
        base.config,
        u,
        preset=base.emulate,
        params=base.params,
        input=r.input,
        one_sign=r.excitation != "friction",
        repeat=repeat,
        dither=dither,
        seed=r.seed,
        loop=None if model is None else speed_loop_plan(r, model, u[:repeat], base.period),
    )
    return Plan(r, cfg, base.emulate is not None)
