"""Plots (needs the ``plot`` extra, matplotlib)."""

from __future__ import annotations

from collections.abc import Sequence

from drivers.errors import ConfigError
from rig.reproduce import DismcRun

__all__ = ["plot_dismc"]


def plot_dismc(runs: Sequence[DismcRun], path: str, *, dt: float) -> None:
    """Write Fig. 3-like plots (sliding functions, tracking errors, control inputs) to ``path``."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ConfigError("--plot needs matplotlib: pip install 'drive-rig[plot]'") from exc
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for run in runs:
        t = [k * dt for k in range(len(run.u))]
        for ax, sig in zip(axes, (run.sigma, run.e, run.u)):
            ax.plot(t, sig, label=run.controller)
    for ax, title in zip(axes, ("(a) sliding functions", "(b) tracking errors", "(c) control inputs")):
        ax.set_title(title)
        ax.grid(True)
    axes[0].legend()
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
