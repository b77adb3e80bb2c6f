"""``lamech simulate FILE --t-end T``: the command-line face of :func:`lamech.simulate`
(imports are lazy so that ``lamech --help`` stays instant)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from typing import TYPE_CHECKING

from ._args import (
    add_tolerance_options,
    assignment,
    evaluate_assignments,
    option_choices,
    option_help,
    options_from,
    positive_float,
    positive_int,
    refuse_overwriting_input,
    samples,
    shown_name,
)
from ._files import add_data_dir
from ._signals import exit_status, noting, signal_name, stop_signals
from ._terms import in_flags

if TYPE_CHECKING:
    from ..model import System

__all__ = ["add_parser", "run"]


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "simulate",
        help="integrate the motion; multipliers, forces, contact events",
        description="Integrate the constrained motion (KKT index-1 form, DOP853 or --method, "
        "projection onto the constraints after every step), locating lift-off, impacts, "
        "slip and stick on the dense output. Prints a summary; writes a CSV "
        "and a plot on request. A run estimated to take over 30 s says so on stderr, "
        "with its progress (and whether the system is stiff). Ctrl-C, SIGTERM and SIGHUP "
        "stop it keeping the trajectory so far (written as asked; exit status 128 + the "
        "signal's number). Chattering contacts stop the run as failed.",
    )
    s.add_argument("problem", help="a .toml problem file or a bundled example name")
    add_data_dir(s)
    s.add_argument(
        "--t-end",
        type=positive_float,
        metavar="T",
        help="end time (start at t = 0); required unless --mode is given "
        "(then four periods of the mode, or three e-folding times)",
    )
    s.add_argument(
        "--mode",
        type=positive_int,
        metavar="K",
        help="start at rest along normal mode K of an equilibrium, numbered as "
        "`lamech modes` lists them (the small oscillation itself, e.g. to animate it)",
    )
    s.add_argument(
        "--equilibrium",
        type=positive_int,
        metavar="N",
        help="with --mode: equilibrium N as `lamech modes` numbers them (default: "
        "the first stable one the constraints can hold, else the first they can hold)",
    )
    s.add_argument(
        "--amplitude",
        type=positive_float,
        default=0.05,
        metavar="A",
        help="with --mode: the largest coordinate's displacement (default %(default)s, "
        "in that coordinate's units: radians for an angle)",
    )
    s.add_argument(
        "--initial",
        action="append",
        default=[],
        type=assignment,
        metavar="NAME=VALUE",
        help="start with coordinate (or velocity x') NAME at VALUE (a number or an "
        "expression of parameters); the other coordinates move to meet the "
        "constraints. Repeatable. E.g. --initial theta1=0.01",
    )
    s.add_argument(
        "--param",
        action="append",
        default=[],
        type=assignment,
        metavar="NAME=VALUE",
        help="override a parameter (or `mu`/`mu:<constraint>`, a friction coefficient). Repeatable",
    )
    s.add_argument(
        "--out",
        metavar="CSV",
        help="write the sampled trajectory (t, coordinates, "
        "velocities x', lambda:<c>, force:<c>:<dir>, energy, residual)",
    )
    grid = s.add_mutually_exclusive_group()
    grid.add_argument(
        "--samples",
        type=samples,
        metavar="N",
        help=option_help("samples", "default 1001"),
    )
    grid.add_argument("--dt", type=positive_float, help=option_help("dt"))
    add_tolerance_options(s)
    s.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    s.add_argument(
        "--plot",
        metavar="PNG",
        help="plot multipliers/forces with the events marked, and the coordinates; with "
        "drives, each drive's force or torque against time and, where it turns its "
        "coordinate, against that angle (matplotlib)",
    )
    s.add_argument(
        "--animate",
        metavar="FILE",
        help="write an animation: .gif, .mp4 (needs ffmpeg) or .html (one "
        "self-contained page): the bodies, their trails, the constraint "
        "forces as arrows, the events",
    )
    s.add_argument(
        "--project-initial",
        action="store_true",
        help="move an initial state that violates the constraints to the nearest "
        "consistent one (mass-matrix metric) instead of failing",
    )
    s.add_argument(
        "--long-run",
        action="store_true",
        help="the run is meant to be long: no warning of its length (by default one is "
        "given after its first 1000 steps when they project beyond a billion steps, and "
        "one after half a second when its pace projects beyond 30 s)",
    )
    s.add_argument(
        "--fps",
        type=positive_float,
        default=20.0,
        help="animation frames per second (default %(default)s)",
    )
    s.add_argument(
        "--duration",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="how long the animation plays (default: the simulated time, "
        "clamped to 2..20 s); the picture states the time scale",
    )
    s.add_argument(
        "--jit",
        action="store_true",
        help="as --engine compiled (kept for older scripts: the compiled engine is the "
        "default now). lamech's engine is C, built when lamech is installed; each "
        "problem's own functions are compiled by the C compiler on its first run (a "
        "fraction of a second) and kept in $LAMECH_CACHE_DIR, else $XDG_CACHE_HOME/lamech, "
        "else ~/.cache/lamech",
    )
    s.add_argument(
        "--engine",
        choices=option_choices("engine", "loop"),
        default="auto",
        help="what integrates (the names of lamech sweep --engine): 'compiled', lamech's "
        "DOP853 loop with events in C (each problem's own functions compiled on its "
        "first run, in a fraction of a second); 'python', the same loop in C with the "
        "problem's functions called back in Python (NumPy, no C compiler needed); "
        "'scipy', SciPy's integrator driven from Python; 'auto' (default) the compiled "
        "loop wherever it can run the problem (DOP853, a C compiler), else SciPy ('loop', "
        "an older name: compiled where the problem is, else Python)",
    )
    return s


MAX_SAMPLES = 10_000_000
"""The most output times one run keeps (about 80 MB per column)."""

PLOT_FORMATS = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp")


def _check_output_size(args, coordinates: int) -> None:
    """ValueError for outputs that cannot be made: more samples than memory holds
    (--dt 1e-12 over a second is 10^12 rows), a plot in a format matplotlib lacks."""
    n = args.samples if args.samples else (int(args.t_end / args.dt) + 1 if args.dt else 1001)
    if n > MAX_SAMPLES:
        gb = n * 8 * (2 * coordinates + 4) / 1e9
        raise ValueError(
            f"{n:.3g} output times (about {gb:.3g} GB) is more than lamech keeps "
            f"({MAX_SAMPLES:.0e}); give fewer with --samples N or a larger --dt"
        )
    if args.plot and not args.plot.lower().endswith(PLOT_FORMATS):
        raise ValueError(
            f"--plot {args.plot}: give a picture file ending in " + ", ".join(PLOT_FORMATS)
        )


def _check_outputs(args) -> None:
    """OutputError (a ValueError) for an output that is not a regular file or whose
    suffix is not its format, before anything runs."""
    from ..outputs import check_output
    from ..present._animate import FORMATS as ANIMATION_FORMATS

    if args.out:
        check_output(args.out, (".csv",), "--out", stdout=True)
    if args.plot:
        check_output(args.plot, PLOT_FORMATS, "--plot")
    if args.animate:
        check_output(args.animate, ANIMATION_FORMATS, "--animate")


def _mode_start(system: System, params: dict, args) -> tuple[System, dict, float, str]:
    """The system started at the chosen equilibrium, initial values along the chosen
    mode, the default end time, and a line saying so (ValueError with what to do when
    there is no such mode). The coordinates the mode does not give start from the
    equilibrium's values, so they are moved onto the constraints on its branch (the
    trammel hanging at y = -l, not above at the file's start)."""
    import math

    from ..model import ModelError, with_values
    from ..symbolic import modes
    from ..symbolic._steady import file_state

    found = modes(with_values(system, parameters=params) if params else system)
    eqs = found.equilibria
    if not eqs:
        raise ValueError(f"--mode: no equilibrium to release the system from ({found.reason})")
    if args.equilibrium is not None:
        if args.equilibrium > len(eqs):
            raise ValueError(
                f"--equilibrium {args.equilibrium}: `lamech modes` finds {len(eqs)} equilibria"
            )
        number = args.equilibrium
    else:
        usable = [i for i, e in enumerate(eqs, 1) if e.exists and e.holds and e.modes]
        stable = [i for i in usable if eqs[i - 1].stability == "stable"]
        if not usable:
            raise ValueError("--mode: no equilibrium the constraints can hold has modes")
        number = (stable or usable)[0]
    e = eqs[number - 1]
    # in the file's coordinates: a chart's angle (the spun hoop's) is not the simulator's
    start = file_state(found.system, e.displaced(args.mode - 1, args.amplitude))
    m = e.modes[args.mode - 1]
    if m.frequency is not None:
        t_end = 4 * 2 * math.pi / m.frequency
        what = f"omega = {m.frequency:.6g} rad/s"
    elif m.growth is not None:
        t_end = 3 / m.growth
        what = f"growth rate {m.growth:.6g} /s"
    else:
        t_end = 1.0
        what = "neutral"
    where = ", ".join(f"{k} = {v:.6g}" for k, v in e.values.items())
    line = (
        f"released at rest along mode {args.mode} ({what}) of equilibrium {number} "
        f"({where}), amplitude {args.amplitude:g}"
    )
    if found.system.chart is None or found.system.chart.automatic:  # the file's coordinates
        at_rest = {c.name: e.values[c.name] for c in system.coordinates}
        at_rest.update({c.name + "'": 0.0 for c in system.coordinates})
        try:
            system = with_values(system, initial=at_rest)
        except (ModelError, ValueError):
            pass  # (a moving constraint: not at rest there) the file's start, as before
    return system, start, t_end, line


def run(args) -> int:
    """Run ``lamech simulate``; returns the exit status (0 ok, 1 run failed, 2 bad input,
    128 + the signal's number when Ctrl-C (130), SIGTERM (143) or SIGHUP (129) stopped
    it: the trajectory up to there is kept and written as asked)."""
    if args.engine == "loop":
        print("lamech: --engine loop is deprecated; use compiled or python", file=sys.stderr)
    phase = ["before the run: nothing was written"]
    with stop_signals():
        try:
            return _run(args, phase)
        except KeyboardInterrupt as exc:  # a signal outside the run itself
            print(f"lamech: stopped by {signal_name(exc)} {phase[0]}", file=sys.stderr)
            return exit_status(exc)


def _run(args, phase: list[str]) -> int:
    from ..numeric import SimulationError, simulate
    from ..numeric._params import check_values
    from ..problem import ProblemFileError, load
    from ..symbolic import DegenerateConstraintsError

    try:
        system = load(args.problem, data_dir=args.data_dir)
    except ProblemFileError as exc:
        print(f"lamech: error in problem file\n{in_flags(str(exc))}", file=sys.stderr)
        return 2
    except DegenerateConstraintsError as exc:
        print(f"lamech: {shown_name(args.problem)}: {in_flags(str(exc))}", file=sys.stderr)
        return 2
    for note in system.notes:  # a T that disagrees with the bodies: say it first
        print(f"lamech: warning: {note}", file=sys.stderr)
    try:
        params = evaluate_assignments(args.param, system, "--param")
        env = dict(system.parameter_values)
        env.update({p.symbol: params[p.name] for p in system.parameters if p.name in params})
        initial = evaluate_assignments(args.initial, system, "--initial", env)
        check_values(system, params, "with these --param values")
        refuse_overwriting_input(
            args.problem, {"--out": args.out, "--plot": args.plot, "--animate": args.animate}
        )
        _check_outputs(args)
        released = None
        if args.mode is not None:
            system, start, t_mode, released = _mode_start(system, params, args)
            initial = {**start, **initial}  # an --initial given as well wins
            if args.t_end is None:
                args.t_end = t_mode
        elif args.equilibrium is not None:
            raise ValueError("--equilibrium chooses where --mode starts: give --mode K too")
        if args.t_end is None:
            raise ValueError("give the end time: --t-end T (or --mode K, which has a default)")
        _check_output_size(args, len(system.coordinates))
    except ValueError as exc:
        print(f"lamech: {shown_name(args.problem)}: {in_flags(str(exc))}", file=sys.stderr)
        return 2
    progress = _Progress(
        args.t_end, bar=sys.stderr.isatty() and not args.json, long_run=args.long_run
    )
    stopped_by: list[BaseException] = []
    try:
        with noting(stopped_by):
            traj = simulate(
                system,
                args.t_end,
                params=params or None,
                initial=initial or None,
                options=options_from(
                    args, jit=True if args.jit or args.engine == "compiled" else None
                ),
                progress=progress,
                pace=progress.pace,
                projection=progress.projection,
            )
    except SimulationError as exc:
        progress.close()
        print(f"lamech: {shown_name(args.problem)}: {in_flags(str(exc))}", file=sys.stderr)
        return 2
    progress.close()
    if traj.status == "interrupted" and stopped_by:
        traj = dataclasses.replace(
            traj,
            message=f"stopped by {signal_name(stopped_by[0])} at t = {traj.final_time:.12g}; "
            "the trajectory up to there is kept",
        )
    phase[0] = (
        "while writing the outputs: those not yet written are missing (a trajectory CSV "
        "is never left half-written)"
    )
    if traj.status == "failed" and traj.steps == 0:
        # Nothing was integrated (a massless body nothing ties, a singular KKT matrix at
        # the initial state): an error in the problem, said in one line; no outputs.
        print(
            f"lamech: {shown_name(args.problem)}: cannot start: {in_flags(traj.message)}",
            file=sys.stderr,
        )
        return 2
    from ..present import to_json, to_text, trajectory_csv

    to_stdout = args.out == "-"  # the table on stdout, the summary beside it on stderr
    if args.out:
        try:
            if to_stdout:
                sys.stdout.write(trajectory_csv(traj) or "")
                sys.stdout.flush()
            else:
                trajectory_csv(traj, args.out)
        except (OSError, ValueError) as exc:
            print(f"lamech: cannot write {args.out}: {exc}", file=sys.stderr)
            return 2
    if args.plot:
        try:
            from ..present import plot_trajectory

            plot_trajectory(traj, args.plot)
        except ImportError as exc:
            print(
                f"lamech: --plot needs matplotlib ({exc}); pip install matplotlib", file=sys.stderr
            )
            return 2
        except (OSError, ValueError) as exc:
            print(f"lamech: cannot write {args.plot}: {exc}", file=sys.stderr)
            return 2
    if args.animate:
        from ..present import animate

        try:
            animate(
                traj,
                system,
                args.animate,
                params=params or None,
                fps=args.fps,
                duration=args.duration,
            )
        except ImportError as exc:
            print(
                f"lamech: --animate needs matplotlib ({exc}); pip install matplotlib",
                file=sys.stderr,
            )
            return 2
        except ValueError as exc:
            print(f"lamech: --animate: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:
            print(f"lamech: cannot write {args.animate}: {exc}", file=sys.stderr)
            return 2
    summary = sys.stderr if to_stdout else sys.stdout
    if args.json:
        print(
            json.dumps(to_json(traj), indent=2, ensure_ascii=False, default=_json_default),
            file=summary,
        )
    else:
        if released:
            print(released, file=summary)
        print(in_flags(to_text(traj)), end="", file=summary)
        if args.out and not to_stdout:
            print(f"  wrote {shown_name(args.out)}", file=summary)
        if args.plot:
            print(f"  wrote {shown_name(args.plot)}", file=summary)
        if args.animate:
            print(f"  wrote {shown_name(args.animate)}", file=summary)
    if traj.status == "interrupted":
        stop = stopped_by[0] if stopped_by else KeyboardInterrupt()
        kept = f"; the trajectory up to there is in {args.out}" if args.out else ""
        print(
            f"lamech: stopped by {signal_name(stop)} at t = {traj.final_time:.12g}{kept}",
            file=sys.stderr,
        )
        return exit_status(stop)
    return 0 if traj.status == "ok" else 1


def _json_default(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


LONG_RUN = 30.0
"""Wall seconds from which a run is long: its estimate is said, and progress shown on
stderr even when it is not a terminal."""
ENDLESS_STEPS = 1e9
"""Projected steps from which a run cannot be expected to end: a billion DOP853 steps
take hours on the compiled loop and days on SciPy's integrator (12 evaluations a step).
Said after the run's first steps (:class:`lamech.numeric._pace.Projection`), from counts
and step sizes, not the clock."""


class _Progress:
    """Progress on stderr. On a terminal (``bar``), a one-line bar after the first second.
    When the run's pace (after the simulator's pilot) says it will take more than
    :data:`LONG_RUN` seconds: one line saying so and how to stop it (and, when its step
    is held down by stability, that the system is stiff and an implicit method is the
    cure); then, when stderr is not a terminal, a line every 10 % or every 5 minutes.
    Earlier, after the run's first steps, when they project beyond :data:`ENDLESS_STEPS`:
    one line saying so, with how to stop it or go on. ``long_run`` (``--long-run``): the
    user means the run to be long, and neither line about its length is written (the
    stiffness advice is)."""

    def __init__(self, t_end: float, bar: bool, long_run: bool = False):
        import time

        self.t_end, self.bar, self.last, self.clock = t_end, bar, -1, time.monotonic
        self.long_run = long_run
        self.start = self.clock()
        self.shown = False
        self.lines = False  # a progress line now and then (not a terminal, a long run)
        self.line_at, self.line_pct = self.start, 0

    def projection(self, p) -> None:
        if self.long_run or p.total < ENDLESS_STEPS:
            return
        sys.stderr.write(
            f"lamech: a run of about {p.total:.2g} steps, more than can be waited for: to "
            f"t = {p.t_end:.4g} at its mean step so far ({p.mean_step:.3g} over its first "
            f"{p.steps} steps), {_duration(p.estimate)} at their pace. Ctrl-C, SIGTERM or "
            "SIGHUP stop it and keep the trajectory so far; a shorter --t-end ends it; "
            "--long-run goes on without this warning\n"
        )
        sys.stderr.flush()

    def pace(self, p) -> None:
        if p.remaining < LONG_RUN:
            return
        if not self.long_run:
            sys.stderr.write(
                f"lamech: a long run: about {_duration(p.estimate)} at its pace so far (t = "
                f"{p.t:.4g} of {p.t_end:.4g} after {p.seconds:.2g} s, {p.steps} steps); "
                "Ctrl-C, SIGTERM or SIGHUP stop it and keep the trajectory so far\n"
            )
        if p.stiff:
            sys.stderr.write(
                f"lamech: the step ({p.step:.2g} s) is held down by stability, not accuracy: "
                f"the system is stiff (its fastest time scale is {p.fastest:.3g} s); "
                "--method Radau (or BDF) takes the steps the motion allows\n"
            )
        sys.stderr.flush()
        self.lines = not self.bar

    def __call__(self, t: float) -> None:
        now = self.clock()
        if now - self.start < 1.0:
            return
        pct = int(100 * t / self.t_end)
        if self.bar and pct != self.last:
            self.last = pct
            bar = "#" * (pct // 4)
            sys.stderr.write(f"\r  simulating [{bar:<25}] {pct:3d}%  t = {t:.4g}")
            sys.stderr.flush()
            self.shown = True
        elif self.lines and (pct >= self.line_pct + 10 or now - self.line_at >= 300):
            self.line_at, self.line_pct = now, pct
            left = (now - self.start) * (self.t_end - t) / t if t > 0 else float("inf")
            sys.stderr.write(
                f"lamech: t = {t:.6g} of {self.t_end:.6g} ({pct}%) after "
                f"{_duration(now - self.start)}; about {_duration(left)} to go\n"
            )
            sys.stderr.flush()

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\r" + " " * 60 + "\r")
            sys.stderr.flush()
            self.shown = False


def _duration(seconds: float) -> str:
    """3.5 s, 12 min, 4.1 h, 54 days, 30000 years."""
    value, unit = seconds, "s"
    for name, size in (("years", 3.15576e7), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            value, unit = seconds / size, name
            break
    return f"{value:.2g} {unit}" if value < 10 else f"{value:.0f} {unit}"
