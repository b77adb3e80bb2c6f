"""lamech's engine in C (issue 45): built when lamech is installed, the same integer codes
as Python reads, clean under ``-Wall -Wextra -Werror``, every array checked where Python
hands it over (a wrong one is a ValueError, never a crash), the same numbers with the
system's compiled functions as with its NumPy functions called back (the engine
"python") on every bundled example, on every road (the loop, the batch loops, SciPy's
integrators applying the engine's rules), a callback's exception raised again in Python,
and (slow) clean under AddressSanitizer and UndefinedBehaviorSanitizer on runs with
lift-off, impacts, Zeno, stick and slip, inputs that switch, the batch loops and SciPy's
road."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.numeric import (
    compile_system,
    compiled_available,
    initial_states,
    integrate_batch,
    integrate_events,
    simulate,
)
from lamech.numeric._cc import compiler
from lamech.numeric._cengine import LIBRARY_ENV, c_kernels
from lamech.numeric._crules import callback_kernels, rules_of
from lamech.numeric._kernels import codes
from lamech.problem import chain_toml

ENGINE = Path(lamech.__file__).parent / "numeric" / "_engine"
SOURCES = sorted(p for p in ENGINE.glob("*.c") if p.name != "module.c")
HERE = Path(__file__).parent
needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler")


def test_the_engine_was_built_at_install_and_runs_the_problems():
    """The README's set-up builds the engine: with a C compiler here, systems run on it."""
    assert compiler() is not None and compiled_available()
    ns = compile_system(lamech.load("cylinder"), jit=None)
    assert ns.jit and ns.jit_cache in ("compiled", "loaded", "memory")
    assert simulate(ns, 0.5, samples=3).engine == "loop (C)"


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
@needs_cc
def test_every_bundled_example_compiles_to_c():
    """Each bundled example's functions compile (pi in a constraint, ``M_PI``, is not
    defined by -std=c99's math.h: the driven four-bar fell back to NumPy silently)."""
    from lamech.numeric._cc import CompileFailed

    for name in EXAMPLES:
        ns = compile_system(lamech.load(name), jit=False)
        try:
            c_kernels(ns.pattern, ns.mass_diagonal, ns.n, ns.m, len(ns.parameters),
                      ns.c_source, ns.switch_slots)  # fmt: skip
        except CompileFailed as exc:
            pytest.fail(f"{name}: {exc}")


def test_the_c_codes_are_pythons_codes():
    text = (ENGINE / "codes.h").read_text()
    found = {k: int(v) for k, v in re.findall(r"#define LM_(\w+) (-?\d+)", text)}
    assert found == codes.constants()


@needs_cc
@pytest.mark.parametrize("source", [p.name for p in SOURCES])
def test_the_c_compiles_without_a_warning(source, tmp_path):
    cc = compiler()
    flags = ["-std=c99", "-O2", "-ffp-contract=off", "-fPIC", "-Wall", "-Wextra", "-Werror",
             "-pedantic", "-Wshadow", "-Wconversion", "-Wno-sign-conversion"]  # fmt: skip
    done = subprocess.run(
        [*cc, *flags, "-c", str(ENGINE / source), "-o", str(tmp_path / "x.o")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr


def _compare(a, b, rel: float = 1e-9) -> None:
    """Two trajectories of the same run: the same events (kind, constraint, time) and the
    same final state and multipliers, to ``rel`` of their scale."""
    assert a.status == b.status, (a.status, b.status, a.message, b.message)
    ka = [(str(e.kind), e.constraint) for e in a.events]
    kb = [(str(e.kind), e.constraint) for e in b.events]
    assert ka == kb
    for ea, eb in zip(a.events, b.events):
        assert abs(ea.t - eb.t) <= rel * max(1.0, abs(ea.t)), (ea, eb)
    scale = 1.0 + np.max(np.abs(a.q[-1])) + np.max(np.abs(a.qd[-1]))
    assert np.max(np.abs(a.q[-1] - b.q[-1])) <= rel * scale
    assert np.max(np.abs(a.qd[-1] - b.qd[-1])) <= rel * scale
    la, lb = np.nan_to_num(a.lambdas[-1]), np.nan_to_num(b.lambdas[-1])
    assert np.max(np.abs(la - lb), initial=0.0) <= rel * (1.0 + np.max(np.abs(la), initial=0.0))


EXAMPLES = sorted(p.stem for p in (Path(lamech.__file__).parent / "examples").glob("*.toml"))
# the squeezer's motion takes milliseconds (its velocities reach 10^4 rad/s by t = 1 s,
# where the loop as Python, with LAPACK's elimination, parts from C by rounding)
T_END = {"andrews_squeezer": 0.003}
PROBLEMS = ["ball", "ball_on_incline", "trammel", "hoop_cartesian", "ellipse_bead"]


@needs_cc
@pytest.mark.parametrize("name", EXAMPLES + [f"problems/{p}" for p in PROBLEMS])
def test_compiled_and_called_back_functions_give_the_same_numbers(name):
    """Every bundled example (and the tests' problems with impacts and Cartesian charts)
    on the engine with its compiled functions and with its NumPy functions called back
    (the engine "python"): the same events and states."""
    system = (
        lamech.load(HERE / f"{name}.toml") if name.startswith("problems/") else lamech.load(name)
    )
    ns = compile_system(system, jit=True)
    assert ns.jit, "every example compiles to C (pi and E included)"
    kw = dict(samples=5, rtol=1e-9, atol=1e-11)
    t_end = T_END.get(name, 1.0)
    c = simulate(ns, t_end, engine="compiled", **kw)
    py = simulate(ns, t_end, engine="python", **kw)
    assert c.engine == "loop (C)" and py.engine == "loop (Python)"
    _compare(c, py)


@needs_cc
def test_the_batch_loops_give_the_same_numbers_with_callbacks():
    compiled = compile_system(lamech.loads(chain_toml(3)), jit=True)
    python = compile_system(lamech.loads(chain_toml(3)), jit=False)
    rng = np.random.default_rng(5)
    a = 0.5 + rng.uniform(-0.3, 0.3, (6, 3))
    xy = np.stack((np.cumsum(np.sin(a), 1), -np.cumsum(np.cos(a), 1)), axis=2).reshape(6, 6)
    Y0 = np.concatenate((xy, np.zeros((6, 6))), axis=1)
    r1 = integrate_batch(compiled, Y0, 1.0, rtol=1e-9, atol=1e-11)
    r2 = integrate_batch(python, Y0, 1.0, rtol=1e-9, atol=1e-11)
    assert r1.ok.all() and (r1.steps == r2.steps).all()
    assert np.max(np.abs(r1.q - r2.q)) < 1e-10 and np.max(np.abs(r1.qd - r2.qd)) < 1e-10
    cyl = compile_system(lamech.load("cylinder"), jit=True)
    P = np.tile(cyl.parameters, (4, 1))
    P[:, cyl.parameter_names.index("R2")] = [0.2, 0.5, 0.8, 1.1]
    starts = initial_states(cyl, P)
    starts[:, cyl.n + cyl.coordinate_names.index("theta1")] = 0.05  # a nudge off the top
    kw = dict(params=P, want=[("lift-off", None)], impacts=True, initial=[("theta1'", 0.05)])
    e1 = integrate_events(cyl, starts, 3.0, jit=True, **kw)
    e2 = integrate_events(cyl, starts, 3.0, jit=False, **kw)
    assert e1.status == e2.status
    for x, y in zip(e1.events, e2.events):
        assert [(e.kind, e.constraint) for e in x] == [(e.kind, e.constraint) for e in y]
        assert all(abs(p.t - q.t) < 1e-10 for p, q in zip(x, y))


@needs_cc
def test_what_python_hands_the_engine_is_checked():
    """Arrays of the wrong shape, type or order, and indices out of range, are refused
    before the engine sees them."""
    ns = compile_system(lamech.load("cylinder"), jit=True)
    k = c_kernels(ns.pattern, ns.mass_diagonal, ns.n, ns.m, len(ns.parameters), ns.c_source,
                  ns.switch_slots)  # fmt: skip
    y = np.zeros(2 * ns.n)
    p = ns.parameters.copy()
    none = np.zeros(0, dtype=np.int64)
    rows = np.arange(ns.m, dtype=np.int64)
    assert k.rhs_kernel(0.0, y, p, rows, none, none, np.zeros(0)).shape == (2 * ns.n,)
    with pytest.raises(ValueError, match="shape"):
        k.rhs_kernel(0.0, np.zeros(3), p, rows, none, none, np.zeros(0))
    with pytest.raises(ValueError, match="outside"):
        k.rhs_kernel(0.0, y, p, rows + 5, none, none, np.zeros(0))
    with pytest.raises(ValueError, match="int64"):
        k.rhs_kernel(0.0, y, p, rows.astype(np.int32), none, none, np.zeros(0))
    with pytest.raises(ValueError, match="shape"):
        k.accelerations(0.0, y, p[:-1])
    free, held = np.zeros(ns.n, bool), np.zeros(ns.n)
    with pytest.raises(ValueError, match="C-contiguous"):  # the engine writes Q in place
        Q = np.zeros((1, 2 * ns.n))[:, ::2]
        k.ev_starts(Q, np.zeros((1, ns.n)), p[None, :], free, free, held, held,
                    np.zeros((3, ns.m), dtype=np.int64), 1e-9)  # fmt: skip
    kinds = np.full((3, ns.m), 7, dtype=np.int64)
    with pytest.raises(ValueError, match="kinds"):
        k.ev_starts(np.zeros((1, ns.n)), np.zeros((1, ns.n)), p[None, :],
                    np.zeros(ns.n, bool), np.zeros(ns.n, bool), np.zeros(ns.n),
                    np.zeros(ns.n), kinds, 1e-9)  # fmt: skip


SCIPY_ROAD = ["ladder", "vertical_circle", "cylinder", "problems/ball", "problems/ball_on_incline",
              "problems/ladder_at_rest"]  # fmt: skip


def _load(name: str):
    if name.startswith("problems/"):
        return lamech.load(HERE / f"{name}.toml")
    return lamech.load(name)


@needs_cc
@pytest.mark.parametrize("name", SCIPY_ROAD)
def test_scipys_road_applies_the_engines_rules_with_either_functions(name):
    """SciPy's integrators apply the engine's rules (rules.c): with the system's compiled
    functions and with its NumPy functions called back, the same events and states; and
    the loop with events agrees with both (one implementation of every rule)."""
    kw = dict(samples=5, rtol=1e-10, atol=1e-12)
    compiled = compile_system(_load(name), jit=True)
    python = compile_system(_load(name), jit=False)
    a = simulate(compiled, 1.5, engine="scipy", **kw)
    b = simulate(python, 1.5, engine="scipy", **kw)
    assert a.engine == b.engine == "SciPy DOP853"
    _compare(a, b, 1e-8)
    assert rules_of(compiled) is not rules_of(python)
    assert rules_of(compiled).k.parallel and not rules_of(python).k.parallel


def test_the_rules_check_what_python_hands_them():
    """The rules' arrays of the wrong shape or type, and indices out of range, are refused
    before the engine sees them."""
    ns = compile_system(lamech.load("ladder"), jit=False)
    rules = rules_of(ns)
    kinds = np.zeros((3, ns.m), dtype=np.int64)
    kinds[2] = -1
    imode = np.ones((4, ns.m), dtype=np.int64)
    imode[1] = 0
    fmode = np.zeros((5, ns.m))
    rows, hrows, sj, sk, sc = rules.ev_mode(kinds, imode, fmode)
    assert list(rows) == list(range(ns.m)) and hrows.shape == sj.shape == (0,)
    y = np.concatenate(ns.initial_state())
    p = ns.parameters.copy()
    with pytest.raises(ValueError, match="shape"):
        rules.ev_project(0.0, y[:-1].copy(), p, rows, hrows, fmode[2].copy())
    with pytest.raises(ValueError, match="outside"):
        rules.ev_project(0.0, y.copy(), p, rows + 9, hrows, fmode[2].copy())
    with pytest.raises(ValueError, match="int64"):
        rules.ev_watch(kinds, imode.astype(np.int32))
    with pytest.raises(ValueError, match="kinds"):
        rules.ev_watch(np.full((3, ns.m), 5, dtype=np.int64), imode)
    tl = codes.tolerances(rtol=1e-8, atol=1e-10, t_end=1.0)
    act = (rows, hrows, sj, sk, sc)
    lim = codes.limits(max_steps=0, impacts=True)
    lg = (np.zeros(4, dtype=np.int64), np.zeros(4, dtype=np.int64), np.zeros(4),
          np.zeros((4, 2 * ns.n)), np.zeros((4, 4)), np.zeros((2, 0), dtype=np.int64),
          np.zeros(0, dtype=np.bool_))  # fmt: skip
    md = (kinds, imode, fmode)
    with pytest.raises(ValueError, match="range"):
        rules.ev_apply(0.0, y.copy(), p, 9, 0, act, md, tl, lim, lg, 0)
    with pytest.raises(ValueError, match="nev"):
        rules.ev_settle(0.0, y.copy(), p, md, tl, lg, 5)
    assert rules.ev_settle(0.0, y.copy(), p, md, tl, lg, 0)[1] == 0


def test_a_callback_that_raises_is_raised_again_in_python():
    """A system's NumPy function called back by the engine: out of an expression's domain
    (ValueError, ArithmeticError) it gives NaN as the compiled C would; any other
    exception it raises returns NaN there and is raised when the engine returns, on every
    road."""
    import dataclasses

    ns = compile_system(lamech.load("pendulum"), jit=False)

    def failing(error):
        def dynamics(t, q, v, p):
            if t > 0.3:
                raise error
            return ns.dynamics(t, q, v, p)

        return dataclasses.replace(ns, dynamics=dynamics)

    broken = failing(RuntimeError("the user's own function"))
    assert broken.replaced
    y0 = np.concatenate(ns.initial_state())
    with pytest.raises(RuntimeError, match="the user's own function"):
        integrate_events(broken, y0[None, :], 1.0, jit=False)
    with pytest.raises(RuntimeError, match="the user's own function"):
        simulate(broken, 1.0, engine="python", samples=3)
    k = callback_kernels(broken)
    with pytest.raises(RuntimeError):
        k.accelerations(0.5, y0, broken.parameters.copy())
    assert np.all(np.isfinite(k.accelerations(0.1, y0, broken.parameters.copy())))
    domain = callback_kernels(failing(ValueError("math domain error")))
    assert np.all(np.isnan(domain.accelerations(0.5, y0, ns.parameters.copy())))


SANITIZED = textwrap.dedent(
    """
    import numpy as np
    import lamech
    from lamech.numeric import compile_system, integrate_batch, simulate
    from lamech.problem import chain_toml

    names = {names!r}
    for name in names:
        system = lamech.load(name) if "/" not in name else lamech.load(name)
        ns = compile_system(system, jit=True)
        assert ns.jit, name
        t = simulate(ns, 1.5, engine="compiled", samples=5)
        print(name, t.engine, t.status, len(t.events))
    ns = compile_system(lamech.loads(chain_toml(4)), jit=True)
    a = np.full((8, 4), 0.4)
    xy = np.stack((np.cumsum(np.sin(a), 1), -np.cumsum(np.cos(a), 1)), axis=2).reshape(8, 8)
    r = integrate_batch(ns, np.concatenate((xy, np.zeros((8, 8))), axis=1), 1.0)
    print("batch", bool(r.ok.all()))
    for name in names:  # SciPy's road on the engine's rules, compiled and called back
        for jit in (True, False):
            ns = compile_system(lamech.load(name), jit=jit)
            t = simulate(ns, 0.5, engine="scipy", samples=3)
            print(name, jit, t.engine, t.status)
    ns = compile_system(lamech.load(names[-1]), jit=False)
    print("python", simulate(ns, 0.5, engine="python", samples=3).engine)
    """
)


@needs_cc
@pytest.mark.slow
def test_the_engine_is_clean_under_address_and_undefined_behaviour_sanitizers(tmp_path):
    """The engine built with ASan and UBSan (any report aborts the process) runs the
    bundled examples (lift-off, friction, inputs, chains), the tests' impacts and Zeno
    ball, and the batch loop."""
    cc = compiler()
    if cc is None or shutil.which(cc[0]) is None:
        pytest.skip("no C compiler")
    asan = subprocess.run([*cc, "-print-file-name=libasan.so"], capture_output=True, text=True)
    runtime = asan.stdout.strip()
    if not runtime or not os.path.isabs(runtime):
        pytest.skip("the compiler has no AddressSanitizer runtime")
    library = tmp_path / "engine_sanitized.so"
    flags = ["-std=c99", "-O1", "-g", "-ffp-contract=off", "-fPIC", "-shared",
             "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
             "-fno-omit-frame-pointer"]  # fmt: skip
    built = subprocess.run([*cc, *flags, "-o", str(library), *map(str, SOURCES), "-lm"],
                           capture_output=True, text=True)  # fmt: skip
    assert built.returncode == 0, built.stderr
    names = EXAMPLES + [str(HERE / "problems" / f"{p}.toml") for p in PROBLEMS]
    env = dict(os.environ, LD_PRELOAD=runtime, ASAN_OPTIONS="detect_leaks=0:abort_on_error=1",
               UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1")  # fmt: skip
    env[LIBRARY_ENV] = str(library)
    done = subprocess.run(
        [sys.executable, "-c", SANITIZED.format(names=names)],
        capture_output=True,
        text=True,
        env=env,
        timeout=1200,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert "ERROR: AddressSanitizer" not in done.stderr and "runtime error" not in done.stderr
    assert "batch True" in done.stdout and "python loop (Python)" in done.stdout
    assert done.stdout.count("SciPy DOP853") == 2 * len(names), done.stdout
    assert done.stdout.count("loop (C)") == len(names), done.stdout
