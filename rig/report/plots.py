"""Plots (needs the ``plot`` extra, matplotlib): what every figure of the toolkit is drawn with.

Every figure has a title, axes labelled with their units and a legend where an axis has more
than one line; a function that draws one returns the figure (closed: written and released) so a
test can read its content. The figures themselves sit beside what they draw: the papers'
reproductions in ``rig.papers.plots``, identification's in ``rig.identify.plots``.
"""

from __future__ import annotations

from typing import Any

from drivers.errors import ConfigError

__all__ = ["require_pyplot", "save"]


def require_pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend; ConfigError naming the extra when it is missing.

    Returns
    -------
    Any
        matplotlib.pyplot.

    Raises
    ------
    ConfigError
        If matplotlib is missing (the extra named).
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ConfigError("--plot needs matplotlib: pip install 'drive-rig[plot]'") from exc
    return plt


def save(plt: Any, fig: Any, path: Any) -> Any:
    """Lay ``fig`` out, write it to ``path``, close it; returns it.

    Parameters
    ----------
    plt : Any
        pyplot.
    fig : Any
        The figure.
    path : Any
        The file.

    Returns
    -------
    Any
        ``fig``.
    """
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return fig
