"""Identification drawn (``rig identify --plot``; needs the ``plot`` extra): the measured speed
and the identified model's, drawn with ``rig.report.plots``."""

from __future__ import annotations

from typing import Any

from rig.report.plots import require_pyplot, save

__all__ = ["plot_identify"]


def plot_identify(run_dir: str, result: object, path: str) -> Any:
    """Write the measured speed (central differences) and the identified model's speed to ``path``.

    Parameters
    ----------
    run_dir : str
        The run.
    result : object
        The identification.
    path : str
        The file.

    Returns
    -------
    Any
        The figure.
    """
    import numpy as np

    from rig.host.rundir import read_run
    from rig.identify.estimate import simulate_positions

    plt = require_pyplot()
    u, theta, dt, _ = read_run(run_dir)
    r: Any = result
    _, w = simulate_positions(np.array([r.a_m, r.b_m, r.offset, theta[0], 0.0]), u, dt, r.delay_samples)
    t = np.arange(len(u)) * dt
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    axes[0].plot(t, np.gradient(theta, dt), label="measured (central differences)")
    axes[0].plot(t, w, label="model")
    axes[0].set_ylabel("speed [rad/s]")
    axes[0].set_title("speed: measured and identified model")
    axes[1].step(t, u, where="post", label="u")
    axes[1].set_ylabel("u [V]")
    axes[1].set_title("input")
    axes[1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True)
    axes[0].legend()
    fig.suptitle(f"rig identify: a_m = {r.a_m:.4g} 1/s, b_m = {r.b_m:.4g} rad/(V s^2)")
    return save(plt, fig, path)
