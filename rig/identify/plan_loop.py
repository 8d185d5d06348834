"""The speed loop of a frequency response measured in closed loop (``rig identify --input torque
--excitation chirp``, or with ``--loop-model``): its gains from an earlier identification's
(a_m, b_m), its speed from the excitation's swing (``rig.identify.closed_loop``).
"""

from __future__ import annotations

from typing import Any

from drivers.errors import ConfigError
from rig.identify.request import PlanError, Request

__all__ = ["loop_model", "speed_loop_plan"]


def loop_model(r: Request) -> tuple[float, float]:
    """(a_m, b_m) of ``--loop-model``, the identification the speed loop's gains come from.

    Parameters
    ----------
    r : Request
        What was asked for.

    Returns
    -------
    tuple[float, float]
        a_m [1/s] and b_m [per unit of the input].

    Raises
    ------
    PlanError
        If there is none, it cannot be read, or its b_m is not > 0 for this input.
    """
    from rig.config.model import read_model

    if r.loop_model is None:
        raise PlanError(
            f"--input torque --excitation {r.excitation}: a torque on a plant with little damping runs "
            "away in open loop; the response is measured under a weak speed loop whose gains need J: give "
            "--loop-model RUN_DIR of a rig identify --input torque (the friction experiment)"
        )
    try:
        model = read_model(r.loop_model, where="rig identify: --loop-model")
    except ConfigError as exc:
        raise PlanError(str(exc).removeprefix("rig identify: ")) from None
    if model.input != r.input or not model.b_m > 0.0:
        raise PlanError(
            f"--loop-model {model.source}: b_m = {model.b_m:g} per unit of {model.input}: "
            f"expected b_m > 0 with --input {r.input} (identify with --input {r.input} first)"
        )
    return model.a_m, model.b_m


def speed_loop_plan(
    r: Request, model: tuple[float, float], excitation: Any, period: float
) -> dict[str, float]:
    """The closed-loop experiment's speed loop for one period of the excitation.

    Parameters
    ----------
    r : Request
        What was asked for, resolved (``rig.identify.request.resolved``).
    model : tuple[float, float]
        (a_m, b_m) the gains are designed for (``loop_model``).
    excitation : Any
        One period of the excitation r about 0 (np.ndarray) [V or N m].
    period : float
        [s] the sample period.

    Returns
    -------
    dict[str, float]
        {"speed" [rad/s], "kp", "ki"}, as ``experiment_config``'s ``loop`` takes it.

    Raises
    ------
    PlanError
        If the loop is not weak over the band, or no speed keeps one sign within the limit.
    """
    from rig.identify.closed_loop import LOOP_FRACTION, SPEED_MARGIN, speed_loop, speed_swing
    from rig.identify.experiment import SPEED_LIMIT

    a, b = model
    bandwidth = LOOP_FRACTION * r.f_min if r.loop_bandwidth is None else r.loop_bandwidth
    if not 0.0 < bandwidth < r.f_min:
        raise PlanError(
            f"argument --loop-bandwidth: {bandwidth:g} Hz: expected 0 < it < --f-min ({r.f_min:g} Hz), a "
            "loop weak over the band measured"
        )
    kp, ki = speed_loop(b, bandwidth)
    swing = speed_swing(excitation, period, a=max(a, 0.0), b=b, kp=kp, ki=ki)
    speed = SPEED_MARGIN * swing if r.speed is None else r.speed
    if not abs(speed) > swing or abs(speed) + swing > SPEED_LIMIT:
        raise PlanError(
            f"the closed-loop experiment's speed {speed:g} rad/s: the excitation swings the speed by "
            f"{swing:.3g} rad/s (--amplitude {r.amplitude:g} at --f-min {r.f_min:g} Hz), so the speed "
            f"needs {swing:.3g} < |--speed| <= {SPEED_LIMIT - swing:.3g} rad/s; lower --amplitude or "
            "raise --f-min"
        )
    return {"speed": speed, "kp": kp, "ki": ki}
