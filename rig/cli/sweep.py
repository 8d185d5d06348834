"""``rig sweep SPEC.toml``: a robustness study on Dask (``rig.sweep``), its table and its plots."""

from __future__ import annotations

import argparse
import signal
import sys
import time
from typing import Any

from rig.cli.common import UsageError, add_json, add_plot, plot_folder, print_json

__all__ = ["add_parser"]


def _workers(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {n}")
    return n


def add_parser(sub: Any) -> None:
    """``rig sweep``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    sweep = sub.add_parser(
        "sweep",
        help="run a robustness study: many emulated runs over varied parameters, on Dask",
        description="Run every point of SPEC.toml (docs/sweeps.md documents it: a rig run "
        "configuration run emulated in lock-step, or a paper's pure simulation, and the parameters "
        "to vary) on Dask: a local cluster of one worker process per core, or an existing cluster "
        "with --scheduler. Rows go to <output>/<name>/results.parquet as points finish, beside "
        "sweep.json; a point that fails is a row with its error. Needs the sweep extra: "
        "pip install 'drive-rig[sweep]'.",
    )
    sweep.add_argument("spec", metavar="SPEC.toml", help="the study (see examples/sweeps/)")
    engine = sweep.add_mutually_exclusive_group()
    engine.add_argument(
        "--workers",
        type=_workers,
        metavar="N",
        help="worker processes of the local cluster (default: one per core)",
    )
    engine.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="use the Dask cluster whose scheduler is at ADDRESS (tcp://HOST:PORT): one started with "
        "'dask scheduler' and 'dask worker ADDRESS --nthreads 1', by dask-jobqueue or on Kubernetes",
    )
    sweep.add_argument(
        "--resume", action="store_true", help="go on with the sweep's table: skip the points in it"
    )
    add_json(sweep, "print one JSON object: the counts, the table's path, the rate, the engine")
    add_plot(sweep, "each metric over one or two varied parameters")
    sweep.set_defaults(handler=execute)


def execute(args: argparse.Namespace) -> int:
    """Run ``rig sweep``: the study's points on a Dask cluster, its table, its plots, its report.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    int
        The exit code (0).

    Raises
    ------
    UsageError
        If Dask or pyarrow is missing.
    """
    try:
        import dask.distributed  # noqa: F401
        import pyarrow  # noqa: F401
    except ImportError as exc:
        raise UsageError(
            f"rig sweep needs Dask and pyarrow ({exc.name} is missing): pip install 'drive-rig[sweep]'"
        ) from None
    from rig.sweep.engine import resumable
    from rig.sweep.load import load_spec

    spec = load_spec(args.spec)
    folder = plot_folder(args, "rig sweep")  # made, and matplotlib checked, before the points
    resumable(
        spec, args.resume
    )  # a folder with a sweep in it, or a changed spec: said before a cluster starts
    done, engine = _points(spec, args)
    plots: list[str] = []
    if folder is not None:
        from rig.sweep.plot import plot_results

        plots = [str(p) for p in plot_results(spec, list(done.results.rows.values()), str(folder))]
    doc = _document(spec, done, engine, plots)
    if args.json:
        print_json(doc)
    else:
        _print_report(spec, done, doc)
    return 0


def _points(spec: Any, args: argparse.Namespace) -> tuple[Any, dict[str, Any]]:
    """(the sweep done, the engine's description): its points run on a cluster, a progress line
    as each finishes; a sweep cut short by a stop signal raises it, saying where its rows are."""
    from rig.cli.progress import Progress
    from rig.sweep.engine import close_client, open_client, run_sweep

    client, engine = open_client(args.workers, args.scheduler, quiet=not args.verbose)
    bar = Progress("rig sweep", 0, "points", json=args.json)
    t0, new = time.monotonic(), [0]

    def on_row(results: Any, total: int) -> None:
        """The progress line: done/total, time left, the rate of this invocation, the failures."""
        new[0] += 1
        rate = new[0] / max(time.monotonic() - t0, 1e-9)
        if bar.total != total:
            bar.cycles(0, total)
        bar.update(results.done, f"{rate:.2f} points/s, {results.failed} failed")

    done = None
    try:
        done = run_sweep(spec, client, engine, resume=args.resume, on_row=on_row)
    finally:
        bar.close()
        close_client(client, quick=done is None or done.interrupted)
    if done.interrupted:  # no table or plots of a cut-short sweep: where its rows are, on stderr
        from rig.host.signals import SIGNALS, StopRequested, taken

        stop = taken() or StopRequested(SIGNALS[signal.SIGINT], signal.SIGINT)
        print(
            f"rig sweep: {done.results.done} of {done.total} points done; --resume runs the others",
            file=sys.stderr,
        )
        raise stop.after(confirmed=None, kept=str(spec.directory / "results.parquet"))
    return done, engine


def _document(spec: Any, done: Any, engine: dict[str, Any], plots: list[str]) -> dict[str, Any]:
    """The sweep's result as ``--json`` prints it."""
    return {
        "sweep_dir": str(spec.directory),
        "results": str(spec.directory / "results.parquet"),
        "points": done.total,
        "done": done.results.done,
        "failed": done.results.failed,
        "resumed": done.resumed,
        "seconds": done.seconds,
        "points_per_s": (done.results.done - done.resumed) / done.seconds if done.seconds > 0 else None,
        "engine": engine,
        "status": done.record["status"],
        "plots": plots,
    }


def _print_report(spec: Any, done: Any, doc: dict[str, Any]) -> None:
    """The sweep's result for a person: its counts, rate and engine, then its files."""
    engine = doc["engine"]
    run = done.total - done.resumed
    rate = f"{doc['points_per_s']:.2f} points/s" if doc["points_per_s"] else "-"
    print(
        f"sweep {spec.name}: {done.results.done} of {done.total} points ({run} to run, "
        f"{done.resumed} resumed), "
        f"{done.results.failed} failed, {done.seconds:.1f} s, {rate} on {engine['workers']} worker(s) "
        f"({engine['kind']} {engine['address']})"
    )
    print(f"results  {doc['results']}")
    print(f"record   {spec.directory / 'sweep.json'}")
    for p in doc["plots"]:
        print(f"plot     {p}")
