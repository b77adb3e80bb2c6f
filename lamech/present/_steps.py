"""``lamech solve --steps``: a :class:`~lamech.symbolic.Derivation` as text or LaTeX.

The lines print in the problem-file grammar (text) or with dotted velocities (LaTeX);
an expression over :data:`READABLE_OPS` operations is summarised by its size, as in
the report.
"""

from __future__ import annotations

import sympy as sp

from ..symbolic import Derivation
from ..symbolic._reduce import READABLE_OPS
from ..symbolic._steps import Term
from ._plain import tex_comment, tex_label, tex_text
from ._report import _t, _tex, latex_names

__all__ = ["steps_text", "steps_latex", "steps_json"]


def _long(expr) -> int | None:
    """The operation count when ``expr`` is too long to print, else None."""
    items = list(expr) if isinstance(expr, sp.MatrixBase) else [expr]
    ops = sum(int(sp.count_ops(e)) for e in items)
    return ops if ops > READABLE_OPS else None


# ----- text -----------------------------------------------------------------------------
def _term_text(term) -> str:
    if not isinstance(term, Term):
        return _t(term)
    of = term.of if isinstance(term.of, str) else _t(term.of)
    by = "" if term.by is None else (term.by if isinstance(term.by, str) else _t(term.by))
    return {
        "": of,
        "d/dq": f"d{of}/d{by}",
        "d/dt d/dq'": f"d/dt d{of}/d{by}",
        "d/dt": f"d{of}/dt",
        "d2/dt2": f"d^2{of}/dt^2",
        "Q": f"Q^({of})_{by}",
        "F": f"F_{of} along {by}",
        "|.|": f"|{of}|",
        "p": f"p_{of}",
    }[term.op]


def _value_text(expr) -> str:
    ops = _long(expr)
    if ops is not None:
        return f"<{ops} operations; in full: lamech solve --json>"
    if isinstance(expr, sp.MatrixBase):
        return "(" + ", ".join(_t(e) for e in expr) + ")"
    return _t(expr)


def steps_text(d: Derivation) -> str:
    """The derivation as plain text, one numbered step after another."""
    head = f"{d.title}: the derivation step by step"
    out = [head, "=" * len(head)]
    for k, step in enumerate(d.steps, 1):
        out += ["", f"Step {k}. {step.title}"]
        for line in step.lines:
            label = f"   [{line.label}]" if line.label else ""
            out.append(f"  {_term_text(line.lhs)} = {_value_text(line.rhs)}{label}")
        out += [f"  note: {n}" for n in step.notes]
    return "\n".join(out) + "\n"


def steps_json(d: Derivation) -> dict:
    """The steps as one JSON object; every expression whole, in the file grammar."""

    def whole(expr) -> str | list[str]:
        if isinstance(expr, sp.MatrixBase):
            return [_t(e) for e in expr]
        return _t(expr)

    return {
        "title": d.title,
        "steps": [
            {
                "title": s.title,
                "lines": [
                    {"lhs": _term_text(x.lhs), "rhs": whole(x.rhs), "label": x.label}
                    for x in s.lines
                ],
                "notes": list(s.notes),
            }
            for s in d.steps
        ],
    }


# ----- LaTeX ----------------------------------------------------------------------------
def _name_tex(name: str) -> str:
    """``f_contact`` -> f_{\\mathrm{contact}}; ``L`` -> L; ``r_rolling`` -> a bold r."""
    base, _, rest = name.partition("_")
    if not rest:
        return base
    sub = rf"_{{{tex_label(rest)}}}"
    return (r"\mathbf{r}" if base == "r" else base) + sub


def _term_tex(term, names) -> str:
    if not isinstance(term, Term):
        return _tex(term, names)
    if isinstance(term.of, str):
        of = _name_tex(term.of)
    else:
        of = _tex(term.of, names)
    by = ""
    if term.by is not None:
        by = tex_label(term.by) if isinstance(term.by, str) else _tex(term.by, names)
    if term.op == "":
        return of
    if term.op == "d/dq":
        return rf"\frac{{\partial {of}}}{{\partial {by}}}"
    if term.op == "d/dt d/dq'":
        return rf"\frac{{d}}{{dt}}\frac{{\partial {of}}}{{\partial {by}}}"
    if term.op == "d/dt":
        return rf"\frac{{d{of}}}{{dt}}"
    if term.op == "d2/dt2":
        return rf"\frac{{d^2{of}}}{{dt^2}}"
    if term.op == "Q":
        return rf"Q^{{({tex_label(str(term.of))})}}_{{{by}}}"
    if term.op == "F":
        return rf"F_{{{tex_label(str(term.of))},\,{by}}}"
    if term.op == "|.|":
        return rf"\left|{of}\right|"
    if term.op == "p":
        return rf"p_{{{_tex(sp.Symbol(str(term.of)), names)}}}"
    raise ValueError(f"unknown term {term.op!r}")


def _value_tex(expr, names) -> str:
    ops = _long(expr)
    if ops is not None:
        return rf"\text{{({ops} operations; in full: lamech solve --json)}}"
    if isinstance(expr, sp.MatrixBase):
        return r"\begin{pmatrix}" + r" \\ ".join(_tex(e, names) for e in expr) + r"\end{pmatrix}"
    return _tex(expr, names)


def step_rows(step, names) -> list[str]:
    """One step's lines as ``aligned`` rows: ``lhs &= rhs && \\text{label}``."""
    rows = []
    for line in step.lines:
        label = rf"\text{{{tex_text(line.label)}}}" if line.label else ""
        rows.append(rf"{_term_tex(line.lhs, names)} &= {_value_tex(line.rhs, names)} && {label}")
    return rows


def steps_latex(d: Derivation, standalone_math: bool = False) -> str:
    """The derivation as LaTeX: a subsection per step, an ``align*`` of its lines, the
    notes as text. ``standalone_math``: for a web page (KaTeX/MathJax), each step's lines
    in one ``$$\\begin{aligned}...$$`` block and no sectioning commands."""
    names = latex_names(d.system)
    parts: list[str] = []
    if not standalone_math:
        title = tex_comment(d.title)
        parts.append(f"% lamech: {title}, step by step\n% requires \\usepackage{{amsmath}}")
    for k, step in enumerate(d.steps, 1):
        rows = step_rows(step, names)
        body = " \\\\\n".join(rows)
        notes = "\n".join(tex_text(n) + "\n" for n in step.notes)
        if standalone_math:
            math = (
                "$$\\begin{aligned}\n" + body.replace("&&", "&\\quad") + "\n\\end{aligned}$$"
                if rows
                else ""
            )
            parts.append(f"% Step {k}. {tex_comment(step.title)}\n{math}\n{notes}")
        else:
            math = f"\\begin{{align*}}\n{body}\n\\end{{align*}}" if rows else ""
            parts.append(
                f"\\subsection*{{Step {k}. {tex_text(step.title)}}}\n{math}\n{notes}".rstrip()
            )
    return "\n\n".join(parts) + "\n"
