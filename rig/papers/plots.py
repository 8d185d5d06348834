"""The papers' reproductions drawn (``rig reproduce ... --plot``; needs the ``plot`` extra).

Fig. 3 of the DISMC paper (``plot_dismc``), Fig. 9(b) of the dq-current paper (``plot_dq_steps``)
and the drives paper's figures of sections VII.B-D (``plot_drives``), drawn with
``rig.report.plots``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rig.papers.dismc import DismcRun
from rig.papers.dq_current import StepRun
from rig.papers.drives_setup import Signals
from rig.report.plots import require_pyplot, save

__all__ = ["DRIVES_PLOTS", "plot_dismc", "plot_dq_steps", "plot_drives"]


def plot_dismc(runs: Sequence[DismcRun], path: str, *, dt: float) -> Any:
    """Write Fig. 3-like plots (sliding functions, tracking errors, control inputs) to ``path``.

    The example of section 4 has no physical units: the signals are dimensionless (-).

    Parameters
    ----------
    runs : Sequence[DismcRun]
        The runs.
    path : str
        The file.
    dt : float
        [s] the period.

    Returns
    -------
    Any
        The figure.
    """
    plt = require_pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for run in runs:
        t = [k * dt for k in range(len(run.u))]
        for ax, sig in zip(axes, (run.sigma, run.e, run.u)):
            ax.plot(t, sig, label=run.controller)
    titles = ("(a) sliding functions", "(b) tracking errors", "(c) control inputs")
    labels = ("sigma_k [-]", "e_k [-]", "u_k [-]")
    for ax, title, label in zip(axes, titles, labels):
        ax.set_title(title)
        ax.set_ylabel(label)
        ax.grid(True)
        ax.legend(fontsize="small")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("DISMC paper, section 4: Fig. 3 (DSMC, DISMC-LMI, DISMC-LQR, DISMC-AW-LQR)")
    return save(plt, fig, path)


def plot_dq_steps(runs: Sequence[StepRun], path: str) -> Any:
    """Write Fig. 9(b)-like plots: i_q and i_d after a unit q step, one panel per strategy and ratio.

    Parameters
    ----------
    runs : Sequence[StepRun]
        The runs.
    path : str
        The file.

    Returns
    -------
    Any
        The figure.
    """
    plt = require_pyplot()
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
        ax.set_ylabel("current [per unit of the q step]")
        ax.grid(True)
        ax.legend(fontsize="small", ncol=3)
    axes[-1, 0].set_xlabel("samples after the step [-]")
    fig.suptitle("dq-current paper: i_q and i_d after a unit q-reference step (Fig. 9(b))")
    return save(plt, fig, path)


#: (experiment, file name) of ``plot_drives``
DRIVES_PLOTS = (
    ("speed_loop", "speed_loop.png"),
    ("position_servo", "position_servo.png"),
    ("im_speed", "im_speed.png"),
    ("cascade", "cascade.png"),
)


#: a panel of ``_panels``: title, y label with its unit, (series, label suffix) pairs, from time [s]
Panel = tuple[str, str, Sequence[tuple[str, str]], float]


def _panels(plt: Any, runs: Sequence[Signals], panels: Sequence[Panel], title: str, path: Any) -> Any:
    """One panel per (title, y label with unit, [(series, line label suffix)], from time [s]),
    a line per run and series (a reference drawn once, from the first run, where its suffix is
    "ref"); the first runs on top, so a relay's band does not hide them."""
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.8 * len(panels)), squeeze=False)
    for ax, (panel_title, ylabel, series, t0) in zip(axes[:, 0], panels):
        for key, suffix in series:
            shown = [r for r in runs if key in r.series][: 1 if suffix == "ref" else None]
            for i, run in enumerate(shown):
                keep = run.t >= t0
                style: dict[str, Any] = {"lw": 0.9, "zorder": 2.0 + (len(shown) - i) / 100}
                if suffix == "ref":
                    style = {"color": "k", "ls": "--", "lw": 1.0, "zorder": 3.0}
                label = key if suffix == "ref" else f"{run.name}{suffix}"
                ax.plot(run.t[keep], run.series[key][keep], label=label, **style)
        ax.set_title(panel_title)
        ax.set_ylabel(ylabel)
        ax.set_xlabel("time [s]")
        ax.grid(True)
        ax.legend(fontsize="x-small", loc="best")
    fig.suptitle(title, fontsize="medium")
    return save(plt, fig, path)


#: per experiment of ``rig reproduce drives``: the figure's title and its panels, after the paper's figures
DRIVES_SPECS: dict[str, tuple[str, Sequence[Panel]]] = {
    "speed_loop": (
        "Figs. 9-10 on the VII.B DC platform (a_m = 16, b_m = 680, T = 0.4 ms):\n"
        "f = 5 h(t-2) sin(5t) V in the control channel, 100 rad/s step at t = 0",
        (
            ("speed response (Fig. 9)", "omega [rad/s]", (("omega", ""),), 0.0),
            ("speed error from 1.5 s", "e = omega* - omega [rad/s]", (("e", ""),), 1.5),
            ("switching function from 1.5 s (Fig. 10)", "g [V s]", (("g", ""),), 1.5),
        ),
    ),
    "position_servo": (
        "Section VII.B: DC position servo, (7.30) h = 16 / h = 0 and the sign law (6.8),\n"
        "load step f = 1000 rad/s^2 at 1.5 s; pure simulation and over the emulated bus",
        (
            ("position (Fig. 12)", "theta [rad]", (("theta_r", "ref"), ("theta", "")), 0.0),
            ("tracking error (Fig. 13)", "e = theta_r - theta [rad]", (("e", ""),), 0.0),
            ("control signal (Fig. 14)", "u [V]", (("u", ""),), 0.0),
        ),
    ),
    "im_speed": (
        "Section VII.C: IM1 speed control, IDTSM (Table IV) vs PI (Table III),\n"
        "T_L = 5 [h(t-2) - h(t-4) + h(t-8) sin(4 pi t)] N m; pure simulation and over the dyno",
        (
            ("speed (Figs. 17-18)", "omega [rad/s]", (("omega_ref", "ref"), ("omega", "")), 0.0),
            ("speed error (Fig. 19)", "e = omega* - omega [rad/s]", (("e", ""),), 0.0),
            ("torque command (Fig. 21) and load", "torque [N m]", (("T_L", "ref"), ("torque", "")), 0.0),
        ),
    ),
    "cascade": (
        "Section VII.D: IM position cascade (Table V, reconstructed (6.36)),\n"
        "the same load; pure simulation and over the dyno",
        (
            ("position tracking (Fig. 22)", "theta [rad]", (("theta_r", "ref"), ("theta", "")), 0.0),
            ("position error (Fig. 23)", "e = theta_r - theta [rad]", (("e", ""),), 0.0),
            (
                "speed reference and speed (Fig. 24)",
                "omega [rad/s]",
                (("omega_ref", ": omega*"), ("omega", ": omega")),
                0.0,
            ),
            ("q-current reference (Fig. 26)", "i_q* [A]", (("i_ref", ""),), 0.0),
        ),
    ),
}


def plot_drives(plots: dict[str, list[Signals]], directory: str) -> dict[str, Any]:
    """Write one figure per experiment of ``rig reproduce drives`` into ``directory``
    (``DRIVES_PLOTS``), with the quantities of the paper's figures; returns them by experiment.

    Parameters
    ----------
    plots : dict[str, list[Signals]]
        Experiment -> signals.
    directory : str
        The folder.

    Returns
    -------
    dict[str, Any]
        Experiment -> figure.
    """
    from pathlib import Path

    plt = require_pyplot()
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, Any] = {}
    for runs_with_error in plots.values():
        for run in runs_with_error:
            s = run.series
            if "theta_r" in s and "theta" in s:
                s["e"] = s["theta_r"] - s["theta"]
            if "omega_ref" in s and "omega" in s and "theta_r" not in s:
                s["e"] = s["omega_ref"] - s["omega"]
    for key, filename in DRIVES_PLOTS:
        if key in plots:
            title, panels = DRIVES_SPECS[key]
            figures[key] = _panels(plt, plots[key], panels, title, out / filename)
    return figures
