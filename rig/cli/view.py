"""``rig view [FOLDER|RUN_DIR ...]``: the read-only web view of runs, studies and identifications
(``rig.view``), and the live scope of a run in progress named by its run directory. ``rig run
--view`` serves the same page beside a run, fed from a ring of the run's rows in shared memory
(``start_beside``)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rig.cli.common import UsageError

if TYPE_CHECKING:
    from drivers.base import AxisDriver
    from rig.config import RigConfig
    from rig.view.beside import SharedView
    from rig.view.process import ViewProcess

__all__ = ["add_parser", "require_view", "start_beside"]

EXTRA = "pip install 'drive-rig[view]'"


def add_parser(sub: Any) -> None:
    """``rig view``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    view = sub.add_parser(
        "view",
        help="serve a read-only web page of runs, studies and a run in progress (a live scope)",
        description="Serve the view from this PC: the run directories under each FOLDER (default: runs "
        "and sweeps, those that exist), newest first, each with its summary, configuration, plots "
        "drawn from its samples, its CAN trace filtered by COB-ID and a second run overlaid; each "
        "study's table and metrics; each identification's Bode plot. A RUN_DIR of a run still "
        "going on (no summary.json yet) is followed live from its samples.csv. Read-only: nothing "
        "can be commanded or written from the page. It binds 127.0.0.1; any other --host needs "
        f"the token it prints at the start. Needs the view extra: {EXTRA}.",
    )
    view.add_argument("folders", nargs="*", metavar="FOLDER|RUN_DIR", help="where the runs and studies are")
    view.add_argument(
        "--host",
        default="127.0.0.1",
        help="the address to listen on (default 127.0.0.1; any other address prints a token that "
        "every request must carry; from a laptop, an SSH tunnel to 127.0.0.1 is safer)",
    )
    view.add_argument(
        "--port", type=_port, default=None, metavar="P", help="the port (default 8050; 0: any free one)"
    )
    view.set_defaults(handler=execute)


def _port(text: str) -> int:
    if not text.isdigit() or int(text) > 65535:
        raise argparse.ArgumentTypeError(f"not a port 0..65535: {text!r}")
    return int(text)


def require_view(who: str) -> None:
    """UsageError naming the extra when Starlette or uvicorn is missing.

    Parameters
    ----------
    who : str
        The command, named in the error.

    Raises
    ------
    UsageError
        If Starlette or uvicorn is missing.
    """
    import importlib.util

    for name in ("starlette", "uvicorn", "websockets"):
        if importlib.util.find_spec(name) is None:
            raise UsageError(f"{who}: the view needs {name}, which is not installed: {EXTRA}")


def _folders(given: list[str]) -> tuple[list[Path], Path | None]:
    """(the folders to show, the run directory to follow live or None); UsageError for a path
    that is not there."""
    paths = [Path(g) for g in given] or [p for p in (Path("runs"), Path("sweeps")) if p.is_dir()]
    for path in paths:
        if not path.is_dir():
            raise UsageError(
                f"rig view: {str(path)!r} is not a folder (give a folder of runs or a run directory)"
            )
    follow = None
    folders = []
    for path in paths:
        in_progress = (path / "samples.csv").exists() and not (path / "summary.json").exists()
        if in_progress and follow is None:
            follow = path
            folders.append(path.parent)  # the run among the others of its folder
        else:
            folders.append(path)
    return folders or [Path(".")], follow


def execute(args: argparse.Namespace) -> int:
    require_view("rig view")
    from rig.view.feed import TailFeed
    from rig.view.scope import Scope
    from rig.view.server import DEFAULT_PORT, ViewServer

    folders, follow = _folders(args.folders)
    scope = Scope() if follow is not None else None
    port = DEFAULT_PORT if args.port is None else args.port
    server = ViewServer(folders, scope, args.host, port, "rig view: --host/--port")
    tail = TailFeed(scope, follow) if scope is not None and follow is not None else None
    if tail is not None:
        tail.start()
    shown = ", ".join(str(f) for f in folders)
    live = f"; following {follow} live" if follow is not None else ""
    print(f"rig view: {server.url}  ({shown}{live}; read-only; Ctrl-C ends it)", flush=True)
    if server.token is not None:
        print(
            "rig view: every request needs the token above; anyone who has it can read the runs", flush=True
        )
    try:
        server.serve()
    finally:
        if tail is not None:
            tail.stop()
        server.sock.close()
    return 0


def start_beside(
    address: str, cfg: RigConfig
) -> tuple[SharedView, Callable[[list[AxisDriver]], None], ViewProcess]:
    """``rig run --view [ADDRESS]``: the server over the run's output folder, started in a process
    of its own (``rig.view.process``: nice, and off the loop's CPU in real time); the live view (a
    ``rig.view.beside.SharedView``: a ring in memory shared with that process, which the recorder
    writes and the process reads ``RATE`` times a second); what gives it the axes once they are
    enabled (their states and faults go into the ring's rows). Its address on stderr.

    Parameters
    ----------
    address : str
        ``--view``'s address.
    cfg : RigConfig
        The run's configuration.

    Returns
    -------
    tuple[SharedView, Callable[[list[AxisDriver]], None], ViewProcess]
        (the live view, what gives it the axes, the server's process).
    """
    require_view("rig run")
    from rig.view.beside import SharedView
    from rig.view.process import ViewProcess
    from rig.view.server import parse_address

    host, port = parse_address(address, "rig run: --view")
    out = Path(cfg.run.output)
    out.mkdir(parents=True, exist_ok=True)
    from rig.host.realtime import loop_cpu

    pinned = loop_cpu(cfg.run.rt_cpu) if cfg.run.time == "realtime" else None
    view = ViewProcess([out], host, port, "rig run: --view", loop_cpu=pinned)
    live = SharedView(view.sink, cfg.run.output)
    print(f"rig run: view at {view.url}  (read-only)", file=sys.stderr, flush=True)
    return live, live.watch, view
