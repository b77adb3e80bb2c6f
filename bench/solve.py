"""B9: a whole `lamech solve` process against a whole SymPy process, in CPU time.

What a user waits for is a whole process: `lamech solve FILE` (import, read, derive,
tidy, print) against a script that imports SymPy, builds the same Lagrangian and
constraints (from `srepr` text written beforehand, outside the time), runs
`LagrangesMethod` + `form_lagranges_equations()` + `solve_multipliers()` and prints the
multipliers. Each side runs as a child process; its CPU time (user + system, from
`resource.getrusage(RUSAGE_CHILDREN)`) is what counts, since the machines are shared and
wall time depends on the neighbours. The runs are interleaved (lamech, SymPy, then the
other way round), beside `python -c "import sympy"` as the floor. Problems: every
bundled example without applied forces (SymPy's LagrangesMethod would need them as a
force list), SymPy's four-bar in relative joint angles (tests/problems), and the double
pendula of B5.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SYMPY_SCRIPT = """
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols
names = {names!r}
vel = {velocities!r}
t = dynamicsymbols._t
q = [dynamicsymbols(n) for n in names]
rep = {{sp.Symbol("t"): t}}
for n, v, f in zip(names, vel, q):
    rep[sp.Symbol(n)] = f
    rep[sp.Symbol(v)] = f.diff(t)
ns = vars(sp)  # the text is SymPy's own srepr, written by bench/solve.py
L = eval({L!r}, ns).xreplace(rep)
hol = [eval(e, ns).xreplace(rep) for e in {hol!r}]
nonhol = [eval(e, ns).xreplace(rep) for e in {nonhol!r}]
lm = LagrangesMethod(L, q, hol_coneqs=hol or None, nonhol_coneqs=nonhol or None)
lm.form_lagranges_equations()
lam = lm.solve_multipliers() if (hol or nonhol) else {{}}  # none to solve for
for k, v in lam.items():
    print(k, "=", v)
"""


def sympy_script(system) -> str:
    import sympy as sp

    # coordinates and velocities as plain symbols the script replaces by dynamicsymbols;
    # the parameters keep lamech's symbols (and their assumptions), as in B5
    plain = {system.t: sp.Symbol("t")}
    for i, c in enumerate(system.coordinates):
        plain[c.symbol] = sp.Symbol(f"q_{i}")
        plain[c.velocity] = sp.Symbol(f"qd_{i}")

    def text(e) -> str:
        return sp.srepr(sp.sympify(e).xreplace(plain))

    return SYMPY_SCRIPT.format(
        names=[f"q_{i}" for i in range(len(system.coordinates))],
        velocities=[f"qd_{i}" for i in range(len(system.coordinates))],
        L=text(system.L),
        hol=[text(c.expr) for c in system.constraints if c.holonomic],
        nonhol=[text(c.expr) for c in system.constraints if not c.holonomic],
    )


def child_cpu(cmd: list[str], timeout: float) -> float | None:
    """CPU seconds (user + system) of one child process; None past ``timeout`` or when it
    fails (its error on stderr)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        subprocess.run(cmd, capture_output=True, timeout=timeout, check=True, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return None
    except subprocess.CalledProcessError as exc:
        print(f"  ({' '.join(cmd[1:])} failed: {exc.stderr.decode()[-300:]})", file=sys.stderr)
        return None
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def problems() -> list[tuple[str, str]]:
    import lamech

    out = []
    for name in lamech.example_names():
        system = lamech.load(name)
        if any(f != 0 for f in system.forces):
            continue
        out.append((name, name))
    four_bar = ROOT / "tests" / "problems" / "four_bar_sympy.toml"
    out.append(("four-bar, SymPy's relative angles", str(four_bar)))
    return out


def bench_solve(lines: list[str], repeats: int = 3, cap: float = 300.0, quick: bool = False):
    import lamech

    py = sys.executable
    print("\nB9  whole process: lamech solve against SymPy's LagrangesMethod, CPU time")
    # lamech byte-compiled, as pip leaves SymPy: where PYTHONDONTWRITEBYTECODE is set,
    # every run would otherwise recompile lamech's modules and not SymPy's
    subprocess.run([py, "-m", "compileall", "-q", str(ROOT / "lamech")], capture_output=True)
    floor = [child_cpu([py, "-c", "import sympy"], cap) for _ in range(repeats)]
    base = statistics.median([f for f in floor if f is not None])
    lines += [
        "## B9 whole process: `lamech solve FILE` against SymPy",
        "",
        __doc__.split("\n\n", 1)[1].replace("\n", " ").strip(),
        "",
        f'`python -c "import sympy"`: {base:.2f} s of CPU (median of {repeats}).',
        "",
        "| problem | lamech solve (CPU s) | SymPy script (CPU s) | lamech / SymPy "
        "| lamech / import sympy |",
        "|---|---|---|---|---|",
    ]
    chosen = problems()
    if quick:
        chosen = [p for p in chosen if p[0] in ("cylinder", "pendulum", "double_pendulum")]
    with tempfile.TemporaryDirectory() as tmp:
        for label, source in chosen:
            system = lamech.load(source)
            script = Path(tmp) / f"{label.replace(' ', '_').replace(',', '')}.py"
            script.write_text(sympy_script(system))
            ours, theirs = [], []
            for r in range(repeats):
                pair = [
                    ("lamech", [py, "-m", "lamech", "solve", source]),
                    ("sympy", [py, str(script)]),
                ]
                for who, cmd in pair if r % 2 == 0 else pair[::-1]:
                    (ours if who == "lamech" else theirs).append(child_cpu(cmd, cap))
            a = statistics.median(x for x in ours if x is not None) if all(ours) else None
            b = statistics.median(x for x in theirs if x is not None) if all(theirs) else None
            ratio = f"{a / b:.2f}×" if a and b else "—"
            cell_a = f"{a:.2f}" if a else f"> {cap:.0f} or failed"
            cell_b = f"{b:.2f}" if b else f"> {cap:.0f} or failed"
            row = (
                f"| {label} | {cell_a} | {cell_b} | {ratio} | "
                f"{(a / base) if a else float('nan'):.1f}× |"
            )
            print("  " + row)
            lines.append(row)
    lines.append("")
