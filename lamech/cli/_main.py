"""The ``lamech`` command: a thin layer over the library (imports are lazy so that
``lamech --help`` is instant)."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time

from .._version import __version__
from ._args import add_assignments, evaluate_assignments
from ._files import add_data_dir
from ._map import add_parser as add_map
from ._report import add_parser as add_report
from ._serve import add_parser as add_serve
from ._simulate import add_parser as add_simulate  # light: argparse only
from ._sweep import add_parser as add_sweep
from ._terms import in_flags

DEFAULT_PROBLEM = "cylinder"


PROGRESS_AFTER = {True: 1.0, False: 10.0}
"""Seconds a solve runs before it says its stage: on a terminal (one line, redrawn), and
into a log or pipe (a line per stage, so a batch job's log shows where a long solve is);
``$LAMECH_PROGRESS_AFTER`` (seconds) sets both."""


def _progress_after(tty: bool) -> float:
    text = os.environ.get("LAMECH_PROGRESS_AFTER", "")
    try:
        return float(text) if text else PROGRESS_AFTER[tty]
    except ValueError:
        return PROGRESS_AFTER[tty]


@contextlib.contextmanager
def _progress():
    """A solve that runs long says on stderr which stage it is in (the symbolic layer's
    stage hook): on a terminal after a second, on one line cleared when it ends; into a
    file or pipe after :data:`PROGRESS_AFTER` seconds, a line for each new stage."""
    from ..symbolic._work import stage_hook

    tty = sys.stderr.isatty()
    after = _progress_after(tty)
    start = time.monotonic()
    shown = [False]
    said: set = set()

    def hook(stage: str) -> None:
        if time.monotonic() - start <= after:
            return
        if tty:
            print(f"\rlamech: solving: {stage} ...\033[K", end="", file=sys.stderr, flush=True)
            shown[0] = True
        elif stage not in said:
            said.add(stage)
            print(f"lamech: solving: {stage} ...", file=sys.stderr, flush=True)

    try:
        with stage_hook(hook):
            yield
    finally:
        if shown[0]:
            print("\r\033[K", end="", file=sys.stderr, flush=True)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number of work units, got {text!r}"
        ) from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number of work units, got {value}")
    return value


def _budget(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--budget",
        type=_positive_int,
        default=None,
        metavar="UNITS",
        help="the work allowed for simplifying the closed forms, counted (not timed), "
        "so the same file prints the same on any machine (default: 20000000; the "
        "multipliers are always given, tidied first; what the budget did not reach is "
        "printed as derived and listed in the notes)",
    )


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="lamech",
        description="Constrained mechanics by Lagrange multipliers. With no arguments, "
        "solves the bundled cylinder-rolling-on-a-cylinder problem.",
    )
    p.add_argument("--version", action="version", version=f"lamech {__version__}")
    sub = p.add_subparsers(dest="command")
    s = sub.add_parser(
        "solve", help="equations, multipliers, forces, lift-off and slip of a problem file"
    )
    s.add_argument(
        "problem",
        nargs="?",
        default=DEFAULT_PROBLEM,
        help="a .toml problem file or a bundled example name "
        f"(default: {DEFAULT_PROBLEM}; see `lamech examples`)",
    )
    add_assignments(
        s,
        "--param",
        "override a parameter's value (or `mu`/`mu:<constraint>`, a friction "
        "coefficient) for the numbers: lift-off and slip angles, the "
        'verdicts at the start; a number, an expression or a quantity ("30 cm"). '
        "Repeatable",
    )
    add_assignments(
        s,
        "--initial",
        "start with coordinate (or velocity x') NAME at VALUE; the other "
        "coordinates move to meet the constraints. Repeatable",
    )
    _angles(s)
    _budget(s)
    add_data_dir(s)
    s.add_argument(
        "--steps",
        action="store_true",
        help="show the derivation step by step, as the lecture writes it: dL/dq, "
        "d/dt dL/dq' and df/dq per coordinate, the equations, the elimination, lambda "
        "solved, the energy integral, lambda on the energy shell, where it vanishes, the "
        "forces by virtual work (with --latex: LaTeX; with --json: JSON)",
    )
    _formats(s)
    md = sub.add_parser(
        "modes",
        help="small oscillations: equilibria, their stability, frequencies and mode shapes",
    )
    md.add_argument(
        "problem",
        nargs="?",
        default=DEFAULT_PROBLEM,
        help="a .toml problem file or a bundled example name",
    )
    add_assignments(md, "--param", "override a parameter's value. Repeatable")
    add_assignments(
        md,
        "--at",
        "linearise about this configuration at rest (every independent coordinate; "
        "values may be expressions such as pi/2) instead of searching for equilibria; "
        'a velocity (--at "phi\'=3.3") makes it a steady motion, such as the conical '
        "pendulum's",
    )
    _angles(md)
    add_data_dir(md)
    _formats(md)
    ex = sub.add_parser(
        "examples",
        help="list the bundled example problems, or print one to copy and change "
        "(lamech examples cylinder > my_problem.toml)",
    )
    ex.add_argument("name", nargs="?", help="a bundled example: print its problem file")
    add_simulate(sub)
    add_sweep(sub)
    add_map(sub)
    add_report(sub)
    add_serve(sub)
    return p


def _angles(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--angles",
        action="store_true",
        help="give the results in angles where a constraint is a sphere in Cartesian "
        "coordinates too (x = l sin(theta) cos(phi), ...: singular at its poles), as a "
        "[parametrisation] in the file would; a circle is solved in its angle "
        "(x1 = l1 sin(theta1), y1 = -l1 cos(theta1)) without it",
    )


def _formats(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--latex", action="store_true", help="print a LaTeX fragment")
    group.add_argument("--json", action="store_true", help="print one JSON object")


def main(argv: list[str] | None = None) -> int:
    """Run ``lamech`` with ``argv`` (default: the command line); return the exit status.

    A reader that closes the pipe early (``lamech examples | head -1``) ends the command
    quietly, as ``cat`` would: no traceback, exit status 141 (128 + SIGPIPE). Ctrl-C
    where no command handles it (while SymPy loads, say) ends it with one line and the
    shell's status for it, 130 (128 + SIGINT).

    Run as the process itself (``argv`` None: the ``lamech`` command, ``python -m
    lamech``), it also sets the process up as :func:`_as_the_process` says.
    """
    process = argv is None
    if process:
        _as_the_process()
    try:
        return _dispatch(_parser().parse_args(sys.argv[1:] if argv is None else argv))
    except KeyboardInterrupt:
        print("lamech: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # Python's recipe: point stdout at /dev/null so that the interpreter's final
        # flush does not raise a second BrokenPipeError on the way out.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    finally:
        if process:
            _ending()


def _as_the_process() -> None:
    """One BLAS thread for the ``lamech`` command's process and those it starts (sweep
    workers), unless the user's environment says otherwise.

    lamech's matrices are small (a KKT system of tens of rows); it runs its own threads
    and processes, and runs BLAS at one thread while it integrates anyway
    (:func:`lamech.numeric._threads.one_blas_thread`). But OpenBLAS starts its pool of
    helper threads when it is loaded, and they spin before they sleep: about 0.1 s of
    CPU for NumPy's OpenBLAS and as much for SciPy's, in every process (measured
    2026-11-27, 2-core VM: ``python -c "import numpy"`` 0.22 s of CPU, 0.10 s with
    ``OPENBLAS_NUM_THREADS=1``). The variable is read when the library loads, so it is
    set here, before the first import of NumPy; the library (``import lamech``) leaves
    its caller's process alone."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _ending() -> None:
    """The command is done and the process ends: move every object to the collector's
    permanent generation (:func:`gc.freeze`), so that the collections at interpreter
    exit do not walk SymPy's millions of objects once more, only to free
    memory the operating system takes back anyway. Measured 2026-11-27 (2-core VM, a
    400-case sweep on the compiled loop): 0.2-0.27 s of CPU after the command's last
    line without it, under 0.05 s with it; a one-case sweep 0.14 s against 0.02 s.
    atexit handlers still run and objects freed by their reference counts still close
    their files; what is no longer freed is an object left in a reference cycle at exit
    (lamech closes its files itself: its tables flush every row and close)."""
    import gc

    gc.freeze()


def _dispatch(args: argparse.Namespace) -> int:
    command = args.command or "solve"
    if command == "simulate":
        from ._simulate import run

        return run(args)
    if command == "serve":
        from ._serve import run as run_serve

        return run_serve(args)
    if command == "report":
        from ._report import run as run_report

        return run_report(args)
    if command == "sweep":
        from ._sweep import run as run_sweep

        return run_sweep(args)
    if command == "map":
        from ._map import run as run_map

        return run_map(args)
    if command == "examples":
        from ..problem import example_names, example_path, example_title

        if args.name is not None:
            if args.name not in example_names():
                print(
                    f"lamech: no bundled example `{args.name}`; known: "
                    + ", ".join(example_names()),
                    file=sys.stderr,
                )
                return 2
            sys.stdout.write(example_path(args.name).read_text(encoding="utf-8"))
            return 0
        for name in example_names():
            print(f"{name:<18} {example_title(name)}")
        return 0
    from ..expr import printable
    from ..present import to_json, to_latex, to_text
    from ..problem import ProblemFileError, load
    from ..symbolic import DegenerateConstraintsError, solve

    problem = getattr(args, "problem", DEFAULT_PROBLEM)
    try:
        system = load(problem, data_dir=getattr(args, "data_dir", None))
        if getattr(args, "param", None) or getattr(args, "initial", None):
            system = _overridden(system, args.param, getattr(args, "initial", []))
        if getattr(args, "angles", False):
            system = _in_angles(system)
        with _progress(), _first_ctrl_c_finishes() as stop:
            solution = solve(system, budget=getattr(args, "budget", None))
        if command == "modes":
            from ..present import modes_latex, modes_text
            from ..symbolic import modes

            at = evaluate_assignments(args.at, system, "--at") if args.at else None
            found = modes(solution, at)
            if args.json:
                print(json.dumps(found.to_json(), indent=2, ensure_ascii=False))
            elif args.latex:
                print(in_flags(modes_latex(found)), end="")
            else:
                print(in_flags(modes_text(found)), end="")
            return 0
    except ProblemFileError as exc:
        print(f"lamech: error in problem file\n{in_flags(str(exc))}", file=sys.stderr)
        return 2
    except (DegenerateConstraintsError, ValueError) as exc:
        text = "\n".join(printable(line) for line in str(exc).split("\n"))
        print(f"lamech: {printable(str(problem))}: {in_flags(text)}", file=sys.stderr)
        return 2
    result: object = solution
    if getattr(args, "steps", False):
        from ..symbolic import steps

        result = steps(solution)  # to_text, to_latex and to_json take a Derivation too
    if getattr(args, "json", False):
        print(json.dumps(to_json(result), indent=2, ensure_ascii=False))
    elif getattr(args, "latex", False):
        print(in_flags(to_latex(result)), end="")
    else:
        print(in_flags(to_text(result)), end="")
    if stop[0]:
        print("lamech: interrupted: the results above are partial", file=sys.stderr)
        return 130
    return 0


@contextlib.contextmanager
def _first_ctrl_c_finishes():
    """Within: a first Ctrl-C stops the simplification, so the solve finishes at once
    with what is done (the rest as derived, the report marked partial); a second one
    interrupts as usual. Outside the main thread (no signals there), nothing changes."""
    import signal
    import threading

    from ..symbolic._work import interruptible

    with interruptible() as flag:
        if threading.current_thread() is not threading.main_thread():
            yield flag
            return

        def first(signum, frame):
            if flag[0]:
                raise KeyboardInterrupt
            flag[0] = True
            signal.signal(signal.SIGINT, signal.default_int_handler)
            print(
                "\nlamech: interrupted: finishing with what is done, untidied "
                "(Ctrl-C again to stop at once)",
                file=sys.stderr,
            )

        previous = signal.signal(signal.SIGINT, first)
        try:
            yield flag
        finally:
            signal.signal(signal.SIGINT, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


def _in_angles(system):
    """``--angles``: the system with the circle/sphere chart of
    :func:`lamech.model.circle_chart` applied, the other constraints on its coordinates
    solved for its angles where they must be (the spun hoop's turning plane:
    :func:`lamech.symbolic._steady.complete_chart`), or an error saying why there is
    none."""
    from ..model import ModelError, circle_chart, with_chart
    from ..symbolic._steady import complete_chart

    if system.chart is not None:
        raise ValueError("--angles: the file already gives a [parametrisation]")
    proposal = circle_chart(system)
    if proposal is None:
        raise ValueError(
            "--angles: no constraint is a circle or sphere in two or three coordinates "
            "not kept (|r - c|^2 = R^2); give a [parametrisation] in the file instead"
        )
    try:
        return with_chart(system, proposal)
    except ModelError as exc:
        completed = complete_chart(system, proposal)
        if completed is None:
            raise ValueError(f"--angles: {exc}") from None
        return completed


def _overridden(system, param_pairs, initial_pairs):
    """The system with ``--param`` and ``--initial`` applied: values are numbers or
    expressions of parameters (the safe parser); held initial values move the other
    coordinates onto the constraints exactly as ``lamech simulate --initial`` does."""
    from ..model import ModelError, with_values
    from ..numeric import compile_system, consistent_initial

    friction = {
        name: text
        for name, text in param_pairs
        if name.startswith("mu") and name not in {p.name for p in system.parameters}
    }
    params = evaluate_assignments(
        [(n, v) for n, v in param_pairs if n not in friction], system, "--param"
    )
    params.update(
        {
            n: float(v)
            for n, v in evaluate_assignments(list(friction.items()), system, "--param").items()
        }
    )
    try:
        system = with_values(system, parameters=params)
        if initial_pairs:
            held = evaluate_assignments(initial_pairs, system, "--initial")
            ns = compile_system(system)
            q, v = consistent_initial(ns, ns.parameter_vector(), list(held.items()))
            names = ns.coordinate_names
            values = {
                **{c: float(x) for c, x in zip(names, q)},
                **{c + "'": float(x) for c, x in zip(names, v)},
            }
            system = with_values(system, initial=values)
    except ModelError as exc:
        raise ValueError(f"with these values: {exc}") from None
    return system
