"""The ``frequency_response`` object of identification.json (``response_document``): the measured
responses of a ``rig.identify.frequency.FrequencyResponse`` in dB and degrees, with the fitted
model's beside them.
"""

from __future__ import annotations

import math

import numpy as np

from rig.identify.frequency import COHERENCE_MIN, FrequencyResponse
from rig.identify.model_response import model_speed_response

__all__ = ["response_document"]


def _db(h: np.ndarray) -> list[float]:
    """20 log10 |h| [dB], a float a bin."""
    return [float(v) for v in 20.0 * np.log10(np.abs(h))]


def _deg(h: np.ndarray) -> list[float]:
    """The unwrapped phase of h [deg], a float a bin."""
    return [float(v) for v in np.degrees(np.unwrap(np.angle(h)))]


def response_document(
    fr: FrequencyResponse, excitation: str, a_m: float, b_m: float, delay: int
) -> dict[str, object]:
    """The ``frequency_response`` object of identification.json: the measured speed and
    position responses, the coherence, the fitted model's speed response (a_m, b_m, the
    delay), the coherent band and the fit's worst deviation within it.

    Parameters
    ----------
    fr : FrequencyResponse
        The measured response.
    excitation : str
        Its excitation's name.
    a_m, b_m : float
        The fitted model (3.5).
    delay : int
        Its delay [samples].

    Returns
    -------
    dict[str, object]
        The object, JSON's types.
    """
    model = model_speed_response(a_m, b_m, fr.dt, delay, fr.f)
    worst_db, worst_deg = fr.deviation(model)
    band = fr.coherent_band()
    return {
        "excitation": excitation,
        "method": fr.method,
        "f_min": fr.f_min,
        "f_max": fr.f_max,
        "averages": fr.averages,
        "dropped": fr.dropped,
        "window": fr.window,
        "coherence_min": COHERENCE_MIN,
        "frequency": [float(v) for v in fr.f],
        "magnitude_db": _db(fr.speed),
        "phase_deg": _deg(fr.speed),
        "position_magnitude_db": _db(fr.position),
        "position_phase_deg": _deg(fr.position),
        "coherence": [float(v) for v in fr.coherence],
        **({} if fr.input_coherence is None else {"input_coherence": [float(v) for v in fr.input_coherence]}),
        **(
            {}
            if fr.velocity is None or fr.velocity_coherence is None
            else {
                "velocity_magnitude_db": _db(fr.velocity),
                "velocity_phase_deg": _deg(fr.velocity),
                "velocity_coherence": [float(v) for v in fr.velocity_coherence],
            }
        ),
        "model_magnitude_db": _db(model),
        "model_phase_deg": _deg(model),
        "coherent_band": None if band is None else list(band),
        "worst_db": None if math.isnan(worst_db) else worst_db,
        "worst_deg": None if math.isnan(worst_deg) else worst_deg,
    }
