"""The Bode plot of ``rig identify``'s frequency response: measured (coherent bins marked), the
fitted model (3.5) beside it, and the coherence; from the ``frequency_response`` document."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["plot_bode"]


def plot_bode(doc: dict[str, Any], path: str) -> Any:
    """Magnitude [dB], phase [deg] and coherence against frequency [Hz] to ``path``; the figure.
    ImportError without matplotlib.

    Parameters
    ----------
    doc : dict[str, Any]
        The ``frequency_response`` document.
    path : str
        The file.

    Returns
    -------
    Any
        The figure.
    """
    from rig.report.plots import require_pyplot

    plt = require_pyplot()
    f = np.asarray(doc["frequency"])
    coherent = np.asarray(doc["coherence"]) >= doc["coherence_min"]
    fig, (mag, phase, coh) = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for ax, measured, model, unit in (
        (mag, "magnitude_db", "model_magnitude_db", "magnitude [dB]"),
        (phase, "phase_deg", "model_phase_deg", "phase [deg]"),
    ):
        values = np.asarray(doc[measured])
        ax.semilogx(f, values, color="0.7", lw=0.8, label="measured")
        ax.semilogx(f[coherent], values[coherent], ".", ms=3, label=f"coherence >= {doc['coherence_min']:g}")
        ax.semilogx(f, doc[model], "k-", lw=1.2, label="fitted model (3.5)")
        ax.set_ylabel(unit)
        ax.grid(True, which="both", alpha=0.4)
    mag.legend(loc="lower left")
    coh.semilogx(f, doc["coherence"])
    coh.axhline(doc["coherence_min"], color="k", ls="--", lw=0.8)
    coh.set_ylim(0.0, 1.05)
    coh.set_ylabel("coherence [-]")
    coh.set_xlabel("frequency [Hz]")
    coh.grid(True, which="both", alpha=0.4)
    worst = (
        ""
        if doc["worst_db"] is None
        else f"\nthe model's worst deviation where coherent: {doc['worst_db']:.2f} dB, "
        f"{doc['worst_deg']:.1f} deg"
    )
    mag.set_title(f"command to speed: {doc['excitation']}, {doc['averages']} averages{worst}")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return fig
