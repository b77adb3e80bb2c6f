"""Argument types shared by the subcommands (argparse only: light to import)."""

from __future__ import annotations

import argparse
import math

__all__ = [
    "add_grid",
    "grid_params",
    "add_tolerance_options",
    "option_choices",
    "option_help",
    "options_from",
    "positive_float",
    "positive_int",
    "shown_name",
    "samples",
    "assignment",
    "evaluate_assignments",
    "add_assignments",
    "refuse_overwriting_input",
]


def positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(x) or x <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive finite number (got {text})")
    return x


def samples(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if n < 2:
        raise argparse.ArgumentTypeError("--samples counts both ends: at least 2")
    return n


def assignment(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"{text!r}: write NAME=VALUE, e.g. theta1=0.01")
    return name.strip(), value.strip()


def add_assignments(parser: argparse.ArgumentParser, flag: str, text: str) -> None:
    """A repeatable NAME=VALUE option (``--param``, ``--initial``, ``--at``)."""
    parser.add_argument(
        flag, action="append", default=[], type=assignment, metavar="NAME=VALUE", help=text
    )


def add_grid(parser: argparse.ArgumentParser) -> None:
    """The grid's repeatable ``--param NAME=VALUES`` (``lamech sweep`` and ``lamech map``)."""
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUES",
        required=True,
        help="a parameter (or `mu`/`mu:<constraint>`, a friction coefficient) and "
        "its values: A:B:N (N values, both ends included; A:A:1 is A), a,b,c "
        "or one value; repeat for a grid",
    )


def grid_params(given: list[str]) -> dict[str, str]:
    """{name: values} of the grid's ``--param`` texts; a name given twice is a
    SweepError."""
    from ..sweeps import SweepError
    from ..sweeps._parse import parse_assignment

    params = dict(parse_assignment(p, "--param") for p in given)
    if len(params) != len(given):
        raise SweepError("a parameter is given twice: " + ", ".join(given))
    return params


def evaluate_assignments(pairs, system, option: str, env=None) -> dict[str, float]:
    """{name: value} from NAME=VALUE pairs; each VALUE a number, a quantity (``30 cm``,
    in SI: issue 46) or an expression of the problem's parameters (``pi/6``,
    ``R1 + R2``), parsed by lamech's safe parser and evaluated at ``env`` (default: the
    file's parameter values)."""
    import sympy as sp

    from ..expr import ExpressionError, is_quantity, parse

    names = {p.name: p.symbol for p in system.parameters}
    env = system.parameter_values if env is None else env
    env = {k: sp.Float(v) if isinstance(v, float) else v for k, v in env.items()}
    out = {}
    for name, text in pairs:
        try:
            if is_quantity(text):  # "30 cm": in SI, of the dimension the file gives it
                value = float(_quantity(text, name, system, option))
            else:
                # a parameter's name alone (theta=theta0) is replaced by a number: sympify
                # makes it a SymPy number again
                expr = parse(text, names, f"{option} {name}")
                value = float(sp.sympify(expr.xreplace(env)))
        except ExpressionError as exc:
            raise ValueError(f"{option} {name}={text}: {exc.message}") from None
        except TypeError:
            raise ValueError(f"{option} {name}={text}: not a real number") from None
        if not math.isfinite(value):
            raise ValueError(f"{option} {name}={text}: not a finite number")
        out[name] = value
    return out


def _quantity(text: str, name: str, system, option: str):
    """The quantity ``text`` of ``NAME=text`` in SI; a ValueError when its dimension is
    not ``name``'s (the problem's, given or inferred; :func:`lamech.model.in_si`)."""
    from ..model import in_si

    return in_si(system, {name: text}, option + " {name}={value}")[name]


def positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1 (got {n})")
    return n


def option_help(name: str, note: str = "") -> str:
    """The help of :class:`lamech.Options`' field ``name``, with its default (and
    ``note``) in parentheses: the command line's text and the library's from one place."""
    field = _option_fields()[name]
    default = field.default
    shown = default not in (None, False) and default != math.inf
    said = "; ".join(
        (
            [f"default {default:g}" if isinstance(default, float) else f"default {default}"]
            if shown
            else []
        )
        + ([note] if note else [])
    )
    return f"{field.metadata['help']} ({said})" if said else field.metadata["help"]


def option_choices(name: str, *older: str) -> tuple[str, ...]:
    """The choices of :class:`lamech.Options`' field ``name`` (and ``older`` names still
    accepted)."""
    return tuple(_option_fields()[name].metadata["choices"]) + older


def _option_fields() -> dict:
    import dataclasses

    from .._options import Options  # light: neither NumPy nor SciPy

    return {f.name: f for f in dataclasses.fields(Options)}


def add_tolerance_options(parser: argparse.ArgumentParser) -> None:
    """--rtol, --atol, --max-step, --method: the integrator's options, the same for
    simulate and sweep, their help, choices and defaults those of :class:`lamech.Options`
    (applied when the option is absent)."""
    parser.add_argument(
        "--rtol", type=positive_float, default=None, help=option_help("rtol", "down to 1e-14")
    )
    parser.add_argument("--atol", type=positive_float, default=None, help=option_help("atol"))
    parser.add_argument(
        "--max-step", type=positive_float, default=None, help=option_help("max_step")
    )
    parser.add_argument(
        "--method", choices=option_choices("method"), default=None, help=option_help("method")
    )


def options_from(args: argparse.Namespace, **more):
    """The :class:`lamech.Options` of the command's arguments (those it has; ``more``
    besides); an absent option keeps its default."""
    from .._options import Options

    given = {k: getattr(args, k) for k in _option_fields() if hasattr(args, k)}
    return Options.merged(None, **{**given, **more})


def refuse_overwriting_input(problem: str, outputs: dict[str, str | None]) -> None:
    """ValueError when an output (``{"--out": path}``) is the problem file itself, by
    any name (a symlink, a hard link, ./ or ../): writing there would replace the
    user's problem with a CSV or a picture. A bundled example's name counts as its
    file."""
    import os
    from pathlib import Path

    from ..problem import example_names, example_path

    source = Path(problem)
    if not source.exists() and not source.suffix and problem in example_names():
        source = example_path(problem)
    if not source.exists():
        return  # the loader says what is wrong with it
    for flag, target in outputs.items():
        if not target:
            continue
        out = Path(target)
        try:
            same = out.exists() and os.path.samefile(out, source)
        except OSError:
            same = False
        if same or out.resolve() == source.resolve():
            raise ValueError(
                f"{flag} {target} is the problem file itself: writing there would replace "
                "it; choose another name"
            )


def shown_name(name) -> str:
    """A file name as a message shows it: control characters escaped
    (:func:`lamech.expr.printable`, imported here so the command line starts without
    SymPy)."""
    from ..expr import printable

    return printable(str(name))
