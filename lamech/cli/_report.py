"""``lamech report FILE -o report.html``: one self-contained HTML page of a problem
(imports are lazy so that ``lamech --help`` stays instant)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ._args import (
    add_assignments,
    evaluate_assignments,
    positive_float,
    refuse_overwriting_input,
    shown_name,
)
from ._files import add_data_dir
from ._terms import in_flags

__all__ = ["add_parser", "run"]

DEFAULT_T_END = 3.0


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "report",
        help="one self-contained HTML page: the problem, the results, the steps, the "
        "force plot, the animation (opens offline)",
        description="Write one HTML file that opens offline (math by an embedded KaTeX, "
        "plots and the animation as embedded images): the problem file, the results of "
        "`lamech solve`, the derivation step by step (`solve --steps`), and a simulation "
        "to --t-end with its force plot, events, animation and summary.",
    )
    s.add_argument(
        "problem",
        nargs="?",
        default="cylinder",
        help="a .toml problem file or a bundled example name (default: cylinder)",
    )
    add_data_dir(s)
    s.add_argument(
        "-o",
        "--out",
        default="report.html",
        metavar="HTML",
        help="the page to write (default %(default)s)",
    )
    s.add_argument(
        "--t-end",
        type=positive_float,
        default=DEFAULT_T_END,
        metavar="T",
        help="simulate to this time for the plot and the animation (default %(default)s)",
    )
    s.add_argument(
        "--no-simulate", action="store_true", help="leave the simulation out (symbolic only)"
    )
    add_assignments(
        s, "--param", "override a parameter for the simulation and the numbers. Repeatable"
    )
    add_assignments(
        s,
        "--initial",
        "start the simulation with coordinate (or velocity x') NAME at VALUE, as "
        "`lamech simulate --initial` (e.g. theta1=0.01 to roll off the top). Repeatable",
    )
    return s


def _source(problem: str) -> str | None:
    from ..problem import example_names, example_path

    p = Path(problem)
    if not p.exists() and not p.suffix and problem in example_names():
        p = example_path(problem)
    try:
        return p.read_text(encoding="utf-8-sig")[:1_000_000]
    except (OSError, UnicodeDecodeError):
        return None


def run(args: argparse.Namespace) -> int:
    try:
        import matplotlib
    except ImportError:
        plots = False  # the page says it has no plots (present._page), and so does the end
    else:
        plots = True
        matplotlib.use("Agg")
    from ..model import ModelError, with_values
    from ..numeric import SimulationError, simulate
    from ..outputs import check_output, write_output
    from ..present import report_page
    from ..problem import ProblemFileError, load
    from ..symbolic import ClosedFormError, DegenerateConstraintsError, solve, steps
    from ..symbolic._selfcheck import check_along

    name = shown_name(args.problem)
    try:
        refuse_overwriting_input(args.problem, {"--out": args.out})
        check_output(args.out, (".html", ".htm"), "--out")
        system = load(args.problem, data_dir=args.data_dir)
        params = evaluate_assignments(args.param, system, "--param") if args.param else {}
        if params:
            system = with_values(system, parameters=params)
        initial = evaluate_assignments(args.initial, system, "--initial") if args.initial else {}
        sol = solve(system)
        derivation = steps(sol)
    except ProblemFileError as exc:
        print(f"lamech: error in problem file\n{in_flags(str(exc))}", file=sys.stderr)
        return 2
    except (DegenerateConstraintsError, ModelError, ValueError) as exc:
        print(f"lamech: {name}: {in_flags(str(exc))}", file=sys.stderr)
        return 2
    traj, note = None, ""
    if initial and not args.no_simulate:
        note = (
            "simulated from "
            + ", ".join(f"{k} = {v:g}" for k, v in initial.items())
            + (" (--initial; the closed forms and the steps are for the file's initial state)")
        )
    if not args.no_simulate:
        try:
            traj = simulate(system, args.t_end, initial=initial or None)
        except SimulationError as exc:
            note = f"no simulation: {exc}"
    if traj is not None and not initial:  # the closed forms are of the file's start
        bad = check_along(
            sol,
            traj.t,
            traj.q,
            traj.qd,
            traj.lambdas,
            until=traj.events[0].t if traj.events else None,
        )
        if bad:
            print(f"lamech: {name}: {ClosedFormError(bad, 'along the motion')}", file=sys.stderr)
            return 2
    page = report_page(sol, derivation, _source(args.problem), traj, None, note)
    out = Path(args.out)
    try:  # beside the target and renamed: a page is never left half-written
        write_output(out, page, (".html", ".htm"))
    except (OSError, ValueError) as exc:
        print(f"lamech: cannot write {shown_name(str(out))}: {exc}", file=sys.stderr)
        return 2
    size = out.stat().st_size
    print(f"wrote {out} ({size / 1e6:.2f} MB)")
    if traj is not None and not plots:
        print("lamech: the page has no plot or animation: they need matplotlib "
              "(pip install matplotlib)", file=sys.stderr)  # fmt: skip
    return 0
