"""The identification experiment: a configuration whose law replays the excitation, run by the session.

The excitation is replayed in voltage mode (the u of (3.5)) on the axis the
configuration's law commands, so it runs with that axis's limits, the watchdog,
the recorder and the one safe-stop path like any ``rig run``: a limit ends it
and keeps what was recorded.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from drivers.files import read_json
from rig.config import AxisConfig, ControllerConfig, RigConfig
from rig.host.rundir import read_run
from rig.host.session import Session
from rig.identify.estimate import IdentificationError, IdentResult, estimate
from rig.identify.frequency import FrequencyResponse

__all__ = [
    "SPEED_LIMIT",
    "Experiment",
    "experiment_config",
    "frequency_from_log",
    "identify_from_log",
    "measure_response",
    "run_controller",
    "run_experiment",
]


#: [rad/s] the experiment's speed limit on the commanded axis
SPEED_LIMIT = 1000.0


@dataclasses.dataclass(frozen=True)
class Experiment:
    """How ``experiment_config`` makes a rig's configuration into an identification run of ``u``
    (one value per period, [V] or, with ``input="torque"``, [N m]).

    Name ``identify``; the law ``replay`` on the axis the configuration's law commands, in voltage
    mode (or CST for a torque: a commercial drive's) with a synchronous RPDO (the delay is
    estimated), no position window, a speed limit of 1000 rad/s; ``preset``/``params`` replace the
    emulator's; ``one_sign``: a change of the speed's sign stops it (false for the friction
    experiment). ``repeat`` > 0: ``u`` repeats with that period [samples], and the law holds one
    period (config.json stays small); ``dither`` > 0: the law adds white noise of that standard
    deviation, seeded by ``seed``. ``loop`` ({"speed", "kp", "ki"}): the closed-loop experiment
    instead, the law ``excited-speed`` (``rig.identify.closed_loop``) with ``u`` the excitation
    added to its command.
    """

    preset: str | None = None  #: the emulator's preset (None: the file's)
    params: dict[str, Any] | None = None  #: its parameters (None: the file's)
    input: str = "voltage"  #: "voltage" or "torque"
    one_sign: bool = True  #: the experiment keeps the speed of one sign (no friction identified)
    repeat: int = 0  #: periods of ``u`` repeated (0: ``u`` once)
    dither: float = 0.0  #: white dither's standard deviation [unit of u]
    seed: int = 0  #: of the dither
    loop: dict[str, float] | None = None  #: a closed speed loop's gains (``excited-speed``; None: open)


def experiment_config(cfg: RigConfig, u: np.ndarray, **options: Any) -> RigConfig:
    """``cfg`` made into an identification run of ``u`` as ``Experiment`` says.

    Parameters
    ----------
    cfg : RigConfig
        The rig.
    u : np.ndarray
        The input per period [V, or N m].
    **options : Any
        ``Experiment``'s fields by name (not given: its defaults).

    Returns
    -------
    RigConfig
        The experiment's configuration.
    """
    e = Experiment(**options)
    target = cfg.controller.commands[0]
    return dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, name=f"identify-{e.input}"),
        emulator=dataclasses.replace(
            cfg.emulator,
            preset=e.preset or cfg.emulator.preset,
            params=cfg.emulator.params if e.params is None else e.params,
        ),
        axes=_experiment_axes(cfg, target, e.input),
        controller=_experiment_law(cfg, u, target, e),
    )


def _experiment_axes(cfg: RigConfig, target: str, input: str) -> tuple[AxisConfig, ...]:
    """``cfg``'s axes, ``target`` in voltage (or CST) mode with a synchronous RPDO, unbounded in
    position and limited to ``SPEED_LIMIT``."""
    return tuple(
        dataclasses.replace(
            a,
            mode="cst" if input == "torque" else "voltage",
            sync_rpdo=True,
            limits=dataclasses.replace(
                a.limits, position_min=-math.inf, position_max=math.inf, speed=SPEED_LIMIT
            ),
        )
        if a.name == target
        else a
        for a in cfg.axes
    )


def _experiment_law(cfg: RigConfig, u: np.ndarray, target: str, e: Experiment) -> ControllerConfig:
    """The law replaying ``u`` on ``target`` (or, ``e.loop`` given, the excited speed loop)."""
    return dataclasses.replace(
        cfg.controller,
        kind="replay" if e.loop is None else "excited-speed",
        reads=(target,),
        commands=(target,),
        params={
            "u": [float(v) for v in (u[: e.repeat] if e.repeat else u)],
            **({"one_sign": e.one_sign} if e.loop is None else dict(e.loop)),
            **({"cycles": len(u)} if e.repeat else {}),
            **({"dither": e.dither, "seed": e.seed} if e.dither else {}),
        },
    )


def run_experiment(
    cfg: RigConfig, *, emulate: bool, progress: Callable[[int, int], None] | None = None
) -> dict[str, Any]:
    """Run the experiment configuration ``cfg`` (``experiment_config``); returns the run summary.
    ``progress(k, cycles)`` every 1 % of it.

    Parameters
    ----------
    cfg : RigConfig
        ``experiment_config``'s.
    emulate : bool
        On the emulator.
    progress : Callable[[int, int], None] | None, optional
        ``progress(k, cycles)``.

    Returns
    -------
    dict[str, Any]
        The run's summary.
    """
    n = cfg.controller.params.get("cycles") or len(cfg.controller.params["u"])
    with Session(cfg, emulate=emulate, cycles=n) as session:
        session.start()
        summary = session.run(None if progress is None else lambda k: progress(k, n))
        summary["period"] = session.timebase.period
    return summary


def identify_from_log(
    run_dir: str | Path, *, max_delay: int = 5, f_min: float | None = None, f_max: float | None = None
) -> IdentResult:
    """Estimate from a recorded run: ``samples.csv`` (command, measurement) on its period's grid
    (the cycles a real-time run skipped filled in: ``read_run``); the input is the commanded
    axis's mode in its ``config.json`` (CST: a torque). Where the speed of an open-loop
    experiment changes sign, (3.5) is estimated with Coulomb friction
    (``rig.identify.friction``); else as (3.5) with an offset, and ``friction`` is estimated
    beside it (closed-loop data) or says that these data cannot separate it (one sign). A
    closed-loop experiment's (law ``excited-speed``) model is fitted to its frequency response
    (``rig.identify.closed_loop.fit_model``) between ``f_min`` (default: its excitation's
    period's) and ``f_max`` (default fs/5) [Hz].

    Parameters
    ----------
    run_dir : str | Path
        The run.
    max_delay : int, optional
        The most delay tried [samples].
    f_min, f_max : float | None, optional
        [Hz] a closed loop's band (None: the defaults).

    Returns
    -------
    IdentResult
        The model.
    """
    from rig.identify.friction import estimate_friction, identify_with_friction, one_sign_result, reverses

    run = read_run(run_dir)
    u, theta, source = run.command, run.measurement, run_input(run_dir)
    if _loop(run_dir) is not None:
        from rig.identify.closed_loop import fit_model

        if f_min is None:
            f_min = 1.0 / (run.period * len(_run_config(run_dir)["controller"]["params"]["u"]))  # type: ignore[index]
        fr = measure_response(run_dir, a_m=math.nan, f_min=f_min, f_max=f_max)
        result = fit_model(fr, u, theta, input=source, max_delay=max_delay)
        return dataclasses.replace(
            result, filled_samples=run.filled, friction=one_sign_result(source).as_dict()
        )
    both_signs = reverses(theta)
    if both_signs and run_controller(run_dir) == "replay":
        result, friction = identify_with_friction(u, theta, run.period, max_delay=max_delay, input=source)
    else:
        result = estimate(u, theta, run.period, max_delay=max_delay, input=source)
        friction = (
            estimate_friction(u, theta, run.period, max_delay=max_delay, input=source)
            if both_signs
            else one_sign_result(source)
        )
    return dataclasses.replace(result, filled_samples=run.filled, friction=friction.as_dict())


def measure_response(
    run_dir: str | Path, *, a_m: float, f_min: float, f_max: float | None
) -> FrequencyResponse:
    """The frequency response of a recorded run (``rig.identify.frequency``); the start's
    transient dropped (SETTLE / ``a_m`` [1/s], or the closed loop's slowest pole); with the
    response to the speed the read axis reported, where it was recorded on the period's grid
    (no skipped cycle). A closed-loop experiment's (law ``excited-speed``) is estimated from
    its recorded excitation r.

    Parameters
    ----------
    run_dir : str | Path
        The run.
    a_m : float
        [1/s] for the transient dropped.
    f_min, f_max
        [Hz] the band (None: fs/5).

    Returns
    -------
    FrequencyResponse
        The response.

    Raises
    ------
    IdentificationError
        If the run has no periodic excitation to measure.
    """
    from rig.identify.closed_loop import settle_time
    from rig.identify.frequency import SETTLE, frequency_response

    run = read_run(run_dir)
    columns = _columns(run_dir) if run.filled == 0 else {}
    velocity, r = columns.get("velocity"), columns.get("excitation")
    loop = _loop(run_dir)
    settle = SETTLE / a_m  # the transient of the start from rest
    if loop is not None:
        if r is None:
            raise IdentificationError(
                f"{run_dir}: a closed-loop experiment without its excitation recorded on the period's "
                "grid (samples.csv's column excitation; a real-time run that skipped cycles)"
            )
        settle = settle_time(loop["kp"], loop["ki"], SETTLE)
    return frequency_response(
        run.command,
        run.measurement,
        run.period,
        f_min=f_min,
        f_max=f_max,
        settle=settle,
        velocity=velocity,
        r=r,
    )


def frequency_from_log(
    run_dir: str | Path, result: IdentResult, excitation: str, *, f_min: float, f_max: float | None
) -> dict[str, Any]:
    """The ``frequency_response`` document of a recorded run (``measure_response``), the fitted
    model ``result``'s response drawn beside it.

    Parameters
    ----------
    run_dir : str | Path
        The run.
    result : IdentResult
        The fitted model.
    excitation : str
        Its name.
    f_min, f_max
        [Hz] the band.

    Returns
    -------
    dict[str, Any]
        The document.
    """
    from rig.identify.frequency_document import response_document

    fr = measure_response(run_dir, a_m=result.a_m, f_min=f_min, f_max=f_max)
    return response_document(fr, excitation, result.a_m, result.b_m, result.delay_samples)


def _columns(run_dir: str | Path) -> dict[str, np.ndarray]:
    """The speed the read axis reported ("AXIS.velocity" in samples.csv) as "velocity", and the
    law's "excitation", where recorded."""
    from rig.host.rundir import read_samples

    config, columns = read_samples(run_dir)
    out = {"excitation": columns["excitation"]} if "excitation" in columns else {}
    try:
        axis = config["controller"]["reads"][0]
    except (KeyError, IndexError, TypeError):
        return out
    if f"{axis}.velocity" in columns:
        out["velocity"] = columns[f"{axis}.velocity"]
    return out


def _loop(run_dir: str | Path) -> dict[str, float] | None:
    """The closed-loop experiment's gains ({"kp", "ki"}), None for another law."""
    cfg: Any = _run_config(run_dir)
    try:
        controller = cfg["controller"]
        if controller["kind"] != "excited-speed":
            return None
        params = controller["params"]
        return {"kp": float(params["kp"]), "ki": float(params.get("ki", 0.0))}
    except (KeyError, TypeError, ValueError):
        return None


def _run_config(run_dir: str | Path) -> dict[str, Any] | None:
    """The run's config.json (None where it is missing or unreadable)."""
    try:
        cfg = read_json(Path(run_dir) / "config.json", what="run configuration")
    except (OSError, ValueError):
        return None
    return cfg if isinstance(cfg, dict) else None


def run_input(run_dir: str | Path) -> str:
    """ "torque" when the run's commanded axis was in CST, else "voltage"."""
    try:
        cfg: Any = _run_config(run_dir)
        commanded = cfg["controller"]["commands"][0]
        mode = next(a["mode"] for a in cfg["axes"] if a["name"] == commanded)
    except (KeyError, IndexError, StopIteration, TypeError):
        return "voltage"
    return "torque" if mode == "cst" else "voltage"


def run_controller(run_dir: str | Path) -> str | None:
    """The kind of the run's law ("replay": the open-loop experiment); None where unknown.

    Parameters
    ----------
    run_dir : str | Path
        The run.

    Returns
    -------
    str | None
        The law's kind, or None.
    """
    try:
        cfg: Any = _run_config(run_dir)
        kind = cfg["controller"]["kind"]
    except (KeyError, TypeError):
        return None
    return kind if isinstance(kind, str) else None
