"""The model (3.5) on disk: ``identification.json``, written by ``rig identify`` into its run
directory, and the ``rig design dtsm --json`` file; read back by ``rig design dtsm
--from-identify`` and by ``[controller] design = "FILE"``, so no number is copied by hand.

``identification.json`` holds a_m [1/s], b_m (per unit of the input: rad/(V s^2), or
1/(kg m^2) for a torque), their standard errors and 95 % intervals, dt [s] (the experiment's
sample period), delay [s] and delay_samples, offset [rad/s^2], fit_percent (held out) with
residual_rms and quantisation_rms [rad/s] (its residual and the encoder's noise floor),
samples, filled_samples (of skipped cycles, filled in), input, input_unit, b_m_unit,
closed_loop and warnings (see ``checks``). A design
file adds the delta-domain design of (6.9), (6.16)-(6.19) and carries a_m, b_m, lam, dt and
input; a ``rig tune --json`` file carries law (the ``[controller] kind``) and params (its
parameters) besides. ``rig.config.model.read_model`` takes any of them, or a run directory holding
identification.json.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rig.config.model import FILE

if TYPE_CHECKING:
    from rig.identify.estimate import IdentResult

__all__ = ["FILE", "FIT_MIN", "checks", "write_identification"]

#: [%] a held-out fit below this is poor: the model does not predict the data it was not fitted to
FIT_MIN = 70.0
#: a residual within this many times the encoder's quantisation noise is that noise (``checks``)
FLOOR_RATIO = 1.5


def checks(result: IdentResult, controller: str | None) -> tuple[bool | None, list[str]]:
    """(closed_loop, warnings) of an identification from a run whose law was ``controller``
    (None: unknown). Closed loop: the law was not one of the experiment's (``replay``, open
    loop; ``excited-speed``, whose excitation is the instrument of the frequency response and
    whose model is fitted to it), so the input depends on the output and least squares is
    biased. A held-out fit below FIT_MIN % is warned only where its residual is above
    FLOOR_RATIO times the encoder's quantisation noise (``rig.identify.estimate``): below, the
    speed barely moves against one count per period (a small chirp or multisine), and what the
    model leaves is the encoder's noise, not a missing dynamic; the frequency response's worst
    deviation is then the measure.

    Parameters
    ----------
    result : IdentResult
        The identification.
    controller : str | None
        The run's law (None: unknown).

    Returns
    -------
    tuple[bool | None, list[str]]
        (closed_loop, warnings).
    """
    warnings = []
    closed = None if controller is None else controller != "replay"
    if closed and controller != "excited-speed":
        warnings.append(
            f"the data were taken in closed loop (controller {controller!r}): the input depends on the "
            "output, so the estimate is biased; identify from an open-loop experiment (rig identify "
            "--config or --emulate)"
        )
    if not result.fit_percent >= FIT_MIN and not result.residual_rms <= FLOOR_RATIO * result.quantisation_rms:
        warnings.append(
            f"the held-out fit is {result.fit_percent:.1f} % (< {FIT_MIN:g} %) and its residual, "
            f"{result.residual_rms:.3g} rad/s RMS, is more than {FLOOR_RATIO:g} times the encoder's "
            f"quantisation noise ({result.quantisation_rms:.3g} rad/s): the model does not predict the data "
            "it was not fitted to"
        )
    return closed, warnings


def write_identification(
    run_dir: Path,
    result: IdentResult,
    closed_loop: bool | None,
    warnings: list[str],
    extra: dict[str, Any] | None = None,
) -> Path:
    """``run_dir``/identification.json (atomically), with ``extra``'s keys (excitation,
    frequency_response, bode_plot, friction); its path.

    Parameters
    ----------
    run_dir : Path
        The run.
    result : IdentResult
        The identification.
    closed_loop : bool | None
        From a closed loop (None: unknown).
    warnings : list[str]
        What to say with it.
    extra : dict[str, Any] | None, optional
        Further keys.

    Returns
    -------
    Path
        The file's path.
    """
    from rig.host.storage import write_atomic

    doc: dict[str, Any] = {
        **result.as_dict(),
        "delay": result.delay_samples * result.dt,
        "closed_loop": closed_loop,
        "warnings": warnings,
        "run_dir": str(run_dir),
        **(extra or {}),
    }
    path = Path(run_dir) / FILE
    write_atomic(path, lambda f: f.write(json.dumps(doc, indent=1) + "\n"))
    return path
