"""``--plot DIR``: the folder a command writes its figures into, made and matplotlib checked
before anything runs."""

from __future__ import annotations

import argparse
import pathlib
import sys

from drivers.errors import ConfigError
from rig.cli.usage import UsageError

__all__ = ["IMAGE_SUFFIXES", "add_plot", "plot_folder"]


#: a name with one of these is a figure's file, not a folder (``--plot``)
IMAGE_SUFFIXES = frozenset({".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp"})


def add_plot(parser: argparse.ArgumentParser, what: str) -> None:
    """``--plot DIR``: ``what`` written into the folder DIR (``plot_folder``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    what : str
        The figures, named in the help.
    """
    parser.add_argument(
        "--plot",
        metavar="DIR",
        help=f"write {what} into the folder DIR (made if missing, before anything runs; needs matplotlib)",
    )


def plot_folder(args: argparse.Namespace, who: str, *, old_file: bool = False) -> pathlib.Path | None:
    """The folder of ``--plot``, made now and matplotlib checked: said before anything runs.

    A name with an image suffix is refused, or, where ``old_file`` (the command wrote one file
    before), taken as the old form for this release: a warning on stderr, and ``args.plot_file``
    is that file (None otherwise).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``args.plot``); ``args.plot_file`` is set.
    who : str
        The command, named in errors.
    old_file : bool, optional
        Take a file name as the deprecated form (the command wrote one file before).

    Returns
    -------
    pathlib.Path | None
        The folder, made; None without ``--plot``.

    Raises
    ------
    UsageError
        If it names a file where a folder is asked for, matplotlib is missing, or the folder
        cannot be made.
    """
    args.plot_file = None
    if args.plot is None:
        return None
    path = pathlib.Path(args.plot)
    folder = path
    if path.suffix.lower() in IMAGE_SUFFIXES and not path.is_dir():
        if not old_file:
            raise UsageError(
                f"{who}: --plot {args.plot}: give a folder (its figures go in it, each named for what it "
                "shows), not a file name"
            )
        folder, args.plot_file = path.parent, str(path)
        print(
            f"{who}: --plot {args.plot}: a file is deprecated (kept for this release): give a folder, "
            f"--plot {folder}",
            file=sys.stderr,
        )
    from rig.report.plots import require_pyplot

    try:
        require_pyplot()
        folder.mkdir(parents=True, exist_ok=True)
    except ConfigError as exc:
        raise UsageError(f"{who}: {exc}") from None
    except OSError as exc:
        raise UsageError(
            f"{who}: --plot {args.plot}: cannot make the folder {folder}: {exc.strerror}"
        ) from None
    return folder
