"""``lamech sweep FILE --param NAME=A:B:N ... --measure liftoff --t-end T``: the
command-line face of :func:`lamech.sweep` (imports are lazy so that ``lamech --help``
stays instant)."""

from __future__ import annotations

import argparse
import math
import sys

from ._args import (
    add_grid,
    add_tolerance_options,
    grid_params,
    option_choices,
    options_from,
    positive_float,
    positive_int,
    shown_name,
)
from ._files import add_data_dir
from ._signals import exit_status, noting, signal_name, stop_signals
from ._terms import in_flags

__all__ = ["add_parser", "run"]


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "sweep",
        help="simulate every combination of parameter values; a table of measures",
        description="Simulate every combination of the swept parameter values (one compiled "
        "system, a different parameter vector per case) and measure each case: "
        "the first lift-off/slip (time and coordinates), the max/min of a "
        "multiplier or force, the final value of a coordinate. Rows are appended "
        "to the table as cases finish; --resume skips the cases already there. "
        "Ctrl-C, SIGTERM and SIGHUP stop it keeping the finished rows, and end its "
        "worker processes.",
    )
    s.add_argument("problem", help="a .toml problem file or a bundled example name")
    add_data_dir(s)
    add_grid(s)
    s.add_argument(
        "--measure",
        action="append",
        default=[],
        metavar="MEASURE",
        help="liftoff, slip, stick, contact, impact (each optionally "
        ":<constraint>), max:<series>, min:<series>, final:<series>; a "
        "series is x, x', lambda:<constraint>, force:<constraint>:<dir>, "
        "energy or residual (default: liftoff)",
    )
    s.add_argument(
        "--t-end",
        type=positive_float,
        required=True,
        metavar="T",
        help="end time of every simulation (start at t = 0)",
    )
    s.add_argument(
        "--initial",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="set an initial coordinate (or velocity x') for every case; the "
        "other coordinates move to meet the constraints",
    )
    s.add_argument(
        "--out",
        metavar="TABLE",
        help="the table: CSV, or Parquet when it ends .parquet (needs pyarrow); "
        "default: CSV on standard output",
    )
    s.add_argument(
        "--plot", metavar="PNG", help="a line plot (one swept parameter) or heat maps (two)"
    )
    s.add_argument(
        "--workers",
        type=positive_int,
        metavar="N",
        help="local worker processes (default: the CPU count)",
    )
    s.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (dask.distributed scheduler address, e.g. tcp://host:8786)",
    )
    s.add_argument(
        "--resume",
        action="store_true",
        help="keep the cases already in --out and run the missing ones and those that "
        "failed; refused when the table was made with other options or another problem "
        "file (recorded beside it in <out>.sweep.json), or when it is damaged (the line "
        "is named)",
    )
    s.add_argument(
        "--samples",
        type=positive_int,
        default=1001,
        metavar="N",
        help="output samples per run, for max/min/final (default %(default)s)",
    )
    s.add_argument(
        "--engine",
        choices=option_choices("engine", "simulate"),
        default="auto",
        help="how the cases run (the names of lamech simulate --engine): the loop with "
        "events where every measure is an event or final:<coordinate> (auto and "
        "compiled: lamech's engine in C, over the cores; python: the same loop as "
        "Python), with simulate for the cases it leaves (failures); scipy: "
        "every case by simulate on --workers processes ('simulate', its older name, is "
        "accepted) (default %(default)s)",
    )
    add_tolerance_options(s)
    return s


def run(args) -> int:
    """Run ``lamech sweep``; exit status 0 every case ok, 1 some case failed (the table
    says which and why), 2 bad input, 128 + the signal's number when Ctrl-C (130),
    SIGTERM (143) or SIGHUP (129) stopped it (the workers end with it; rerun with
    --resume)."""
    if args.engine == "simulate":
        print("lamech: --engine simulate is deprecated; use scipy", file=sys.stderr)
    with stop_signals():
        try:
            return _run(args)
        except KeyboardInterrupt as exc:  # before the cases ran
            print(f"lamech: stopped by {signal_name(exc)} before any case ran", file=sys.stderr)
            return exit_status(exc)


def _run(args) -> int:
    from ..outputs import OutputError, check_output
    from ..present import plot_sweep
    from ..problem import ProblemFileError, load
    from ..sweeps import SweepError
    from ..sweeps._parse import parse_assignment
    from ..sweeps._run import execute
    from ..symbolic import DegenerateConstraintsError
    from ._args import refuse_overwriting_input
    from ._simulate import PLOT_FORMATS

    stopped_by: list[BaseException] = []
    try:
        params = grid_params(args.param)
        initial = dict(parse_assignment(p, "--initial") for p in args.initial)
        if args.out == "-":
            args.out = None  # the table on standard output, as without --out
        try:  # the most specific message first: the problem file itself
            refuse_overwriting_input(args.problem, {"--out": args.out, "--plot": args.plot})
        except ValueError as exc:
            raise SweepError(str(exc)) from None
        if args.out:
            check_output(args.out, (".csv", ".parquet"), "--out", stdout=True)
        if args.plot:
            check_output(args.plot, PLOT_FORMATS, "--plot")
        if args.resume and not args.out:
            raise SweepError("--resume needs --out (the table to resume)")
        if args.out and args.out.lower().endswith(".parquet"):
            try:
                import pyarrow  # noqa: F401
            except ImportError:
                raise SweepError(
                    "a .parquet table needs pyarrow (and pandas): pip install "
                    "pyarrow pandas; or write a .csv"
                ) from None
        with noting(stopped_by):
            result = execute(
                load(args.problem, data_dir=args.data_dir) if args.data_dir else args.problem,
                params,
                args.measure or ["liftoff"],
                t_end=args.t_end,
                initial=initial,
                out=args.out,
                resume=args.resume,
                workers=args.workers,
                scheduler=args.scheduler,
                options=options_from(args),
            )
    except ProblemFileError as exc:
        print(f"lamech: error in problem file\n{in_flags(str(exc))}", file=sys.stderr)
        return 2
    except (SweepError, DegenerateConstraintsError, OutputError) as exc:
        print(f"lamech: {shown_name(args.problem)}: {in_flags(str(exc))}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"lamech: {exc}", file=sys.stderr)
        return 2
    if result.interrupted:
        stop = stopped_by[0] if stopped_by else KeyboardInterrupt()
        print(
            f"lamech: stopped by {signal_name(stop)}: {len(result.rows)} of "
            f"{_total(result)} cases done"
            + (f" and kept in {args.out}; rerun with --resume to finish" if args.out else ""),
            file=sys.stderr,
        )
        return exit_status(stop)
    if result.stopped:
        print(
            f"lamech: the sweep stopped ({result.stopped}): {len(result.rows)} of "
            f"{_total(result)} cases done"
            + (f" and kept in {args.out}; rerun with --resume to finish" if args.out else ""),
            file=sys.stderr,
        )
        return 1
    if not args.out:
        _print_csv(result)
    out = sys.stdout if args.out else sys.stderr
    counts = ", ".join(f"{k} {v}" for k, v in sorted(result.counts.items()))
    sizes = ", ".join(f"{n}: {len(a)}" for n, a in result.parameters.items())
    print(
        f"{len(result.rows)} cases ({sizes}): {counts}; ran {result.ran}"
        + (f", kept {result.kept} from the table" if result.kept else "")
        + (f", retried {result.retried} that had failed" if result.retried else "")
        + f" in {result.seconds:.3g} s on {result.backend}",
        file=out,
    )
    if result.units:  # issue 46: the SI unit of each column whose dimension is known
        print("  units (SI): " + ", ".join(f"{k} {u}" for k, u in result.units.items()), file=out)
    failed = [r for r in result.rows if r["status"] != "ok"]
    for r in failed[:3]:
        where = ", ".join(f"{n} = {r[n]:g}" for n in result.parameters)
        message = in_flags(r["message"])
        print(f"  case {r['case']} ({where}): {r['status']}: {message}", file=sys.stderr)
    if len(failed) > 3:
        print(
            f"  ... and {len(failed) - 3} more (see the status and message columns)",
            file=sys.stderr,
        )
    if args.out:
        print(f"  wrote {shown_name(args.out)}", file=out)
    if args.plot:
        try:
            plot_sweep(result, args.plot)
        except SweepError as exc:
            print(f"lamech: --plot: {exc}", file=sys.stderr)
            return 2
        except (OSError, ValueError) as exc:
            print(f"lamech: cannot write {args.plot}: {exc}", file=sys.stderr)
            return 2
        print(f"  wrote {shown_name(args.plot)}", file=out)
    return 0 if set(result.counts) <= {"ok"} else 1


def _total(result) -> int:
    return math.prod(len(a) for a in result.parameters.values())


def _print_csv(result) -> None:
    from ..present import to_csv

    sys.stdout.write(to_csv(result) or "")
