"""Plots (needs the ``plot`` extra, matplotlib)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from drivers.errors import ConfigError
from rig.papers.dismc import DismcRun
from rig.papers.dq_current import StepRun

__all__ = ["plot_dismc", "plot_dq_steps"]


def _pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ConfigError("--plot needs matplotlib: pip install 'drive-rig[plot]'") from exc
    return plt


def plot_dismc(runs: Sequence[DismcRun], path: str, *, dt: float) -> None:
    """Write Fig. 3-like plots (sliding functions, tracking errors, control inputs) to ``path``."""
    plt = _pyplot()
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


def plot_dq_steps(runs: Sequence[StepRun], path: str) -> None:
    """Write Fig. 9(b)-like plots: i_q and i_d after a unit q step, one panel per strategy and ratio."""
    plt = _pyplot()
    panels = sorted({(r.strategy, r.ratio) for r in runs}, key=lambda p: (p[0], -p[1]))
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.6 * len(panels)), squeeze=False)
    for ax, (strategy, ratio) in zip(axes[:, 0], panels):
        for run in (r for r in runs if (r.strategy, r.ratio) == (strategy, ratio)):
            k = range(len(run.i))
            line = ax.step(k, run.i.imag, where="post", label=f"{run.controller} i_q")[0]
            ax.step(
                k, run.i.real, where="post", ls="--", color=line.get_color(), label=f"{run.controller} i_d"
            )
        ax.set_title(f"{strategy}, omega_k/omega_s = 1/{1 / ratio:.4g}")
        ax.set_xlim(0, 20)
        ax.grid(True)
    axes[0, 0].legend(fontsize="small", ncol=3)
    axes[-1, 0].set_xlabel("samples after the step")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_identify(run_dir: str, result: object, path: str) -> None:
    """Write the measured speed (central differences) and the identified model's speed to ``path``."""
    import numpy as np

    from rig.host.rundir import read_run
    from rig.identify.estimate import simulate_positions

    plt = _pyplot()
    u, theta, dt = read_run(run_dir)
    r: Any = result
    _, w = simulate_positions(np.array([r.a_m, r.b_m, r.offset, theta[0], 0.0]), u, dt, r.delay_samples)
    t = np.arange(len(u)) * dt
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    axes[0].plot(t, np.gradient(theta, dt), label="measured (central differences)")
    axes[0].plot(t, w, label="model")
    axes[0].set_ylabel("speed [rad/s]")
    axes[1].step(t, u, where="post")
    axes[1].set_ylabel("u [V]")
    axes[1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True)
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
