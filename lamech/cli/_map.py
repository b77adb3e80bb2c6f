"""``lamech map FILE --param mu=0.05:0.6:1000 --param R2=0.1:1:1000 [--measure slip]
--out map.csv|.png|.svg``: the command-line face of :func:`lamech.map`, the closed-form
event angles over a grid of parameters, without simulating."""

from __future__ import annotations

import argparse
import sys

from ._args import add_grid, grid_params, shown_name
from ._files import add_data_dir
from ._terms import in_flags

__all__ = ["add_parser", "run"]


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "map",
        help="regimes over a grid of parameters from the closed forms (no simulation)",
        description="Evaluate the closed-form event angles (where a contact lets go, where a "
        "rolling contact slips), the 'at the start' verdicts and which event comes first "
        "at every combination of the parameter values, vectorised, without simulating "
        "(a motion of one degree of freedom with an energy integral; `lamech sweep` "
        "simulates the rest). The columns are those `lamech sweep` writes for the same "
        "measures (the time of an event is nan: it has no closed form here), then "
        "<measure>:start and first.",
    )
    s.add_argument("problem", help="a .toml problem file or a bundled example name")
    add_data_dir(s)
    add_grid(s)
    s.add_argument(
        "--measure",
        action="append",
        default=[],
        metavar="MEASURE",
        help="slip or liftoff (each optionally :<constraint>); default: both",
    )
    s.add_argument(
        "--out",
        metavar="FILE",
        help="the table (.csv) or a picture of the regions (.png, .svg); default: CSV on "
        "standard output",
    )
    return s


def run(args) -> int:
    from ..outputs import OutputError, check_output, write_output
    from ..problem import ProblemFileError, load
    from ..sweeps import SweepError, parameter_map
    from ..symbolic import DegenerateConstraintsError

    try:
        params = grid_params(args.param)
        if args.out == "-":
            args.out = None
        if args.out:
            check_output(args.out, (".csv", ".png", ".svg"), "--out", stdout=True)
        system = load(args.problem, data_dir=args.data_dir) if args.data_dir else args.problem
        result = parameter_map(system, params, args.measure or None)
        if args.out and args.out.lower().endswith((".png", ".svg")):
            from ..present import plot_map

            plot_map(result, args.out)
        else:
            from ..present import to_csv

            text = to_csv(result) or ""
            if args.out:
                write_output(args.out, text, (".csv",), flag="--out")
            else:
                sys.stdout.write(text)
    except ProblemFileError as exc:
        print(f"lamech: error in problem file\n{in_flags(str(exc))}", file=sys.stderr)
        return 2
    except (SweepError, DegenerateConstraintsError, OutputError) as exc:
        print(f"lamech: {shown_name(args.problem)}: {in_flags(str(exc))}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"lamech: {exc}", file=sys.stderr)
        return 2
    counts: dict[str, int] = {}
    for v in result.columns["first"]:
        counts[v] = counts.get(v, 0) + 1
    rate = len(result) / result.seconds if result.seconds > 0 else float("inf")
    regions = ", ".join(f"{k}: {v}" for k, v in sorted(counts.items()))
    print(
        f"{len(result)} points in {result.seconds:.3g} s of CPU ({rate:.3g} points/s) from "
        f"the closed forms; first event: {regions}",
        file=sys.stderr,
    )
    for note in result.notes:
        print(f"  note: {note}", file=sys.stderr)
    if args.out:
        print(f"  wrote {shown_name(args.out)}", file=sys.stderr)
    return 0
