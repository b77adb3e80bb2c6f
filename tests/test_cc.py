"""A system's functions compiled by the C compiler (`numeric/_cc.py`): the C printed
from the same subexpressions gives the generated Python's numbers, is built once into
the cache folder, a missing or failing compiler is no error (NumPy and SciPy run the
system), and the engine in C runs the C functions with SciPy's path's numbers."""

from __future__ import annotations

import ctypes
import tempfile
from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.numeric import compile_system, simulate
from lamech.numeric._cc import FUNCTIONS, CompileFailed, compiler, load
from lamech.problem import chain_toml, example_path


def _cc_works() -> bool:
    """Whether the machine's C compiler builds a library with ``math.h`` (a compiler
    without the C library's headers is no compiler here: NumPy's route runs)."""
    if compiler() is None:
        return False
    body = "#include <math.h>\n" + "\n".join(f"void {f}(void) {{}}" for f in FUNCTIONS)
    with tempfile.TemporaryDirectory() as tmp:
        try:  # a kernels folder in a private one, as lamech's (not beside /tmp's others)
            load(body, Path(tmp) / "kernels")
        except CompileFailed:
            return False
    return True


needs_cc = pytest.mark.skipif(not _cc_works(), reason="no working C compiler")

# M diagonal (maximal coordinates) and not, friction, restitution, a moving support
SYSTEMS = ["cylinder", "double_pendulum", "incline_disk", "moving_support", "heavy_top"]


def _compiled(text: str):
    """The system's NumPy functions and its C source (nothing compiled)."""
    ns = compile_system(lamech.loads(text), jit=False)
    return ns, ns.c_source


def _c_call(lib, name: str, shapes: list, t: float, *inputs: np.ndarray) -> list:
    """One C function called with zeroed outputs of ``shapes``."""
    outs = [np.zeros(s) for s in shapes]
    args = [np.ascontiguousarray(a, dtype=float) for a in inputs]
    f = getattr(lib, name)
    f.restype = None
    f(ctypes.c_double(t), *(ctypes.c_void_p(a.ctypes.data) for a in (*args, *outs)))
    return outs


# the cases of 2 s or more: left out of the default set
SLOW = {"double_pendulum", "incline_disk", "moving_support", "heavy_top"}
assert SLOW <= set(SYSTEMS), SLOW - set(SYSTEMS)


@needs_cc
@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in SYSTEMS]
)
def test_the_c_functions_give_the_generated_pythons_numbers(name, tmp_path):
    ns, c_source = _compiled(example_path(name).read_text(encoding="utf-8"))
    assert c_source, "every bundled example has a C form"
    lib, addresses, state = load(c_source, tmp_path)
    assert state == "compiled" and all(addresses)
    n, m = ns.n, ns.m
    PTR, IDX = ns.pattern[0], ns.pattern[1]
    rng = np.random.default_rng(7)
    p = ns.parameters.copy()
    for _ in range(5):
        t, q, v = float(rng.uniform(0, 2)), rng.uniform(-1, 1, n), rng.uniform(-2, 2, n)
        want = ns.dynamics(t, q, v, p)
        got = _c_call(lib, "c_dynamics", [(n, n), n, (m, n), m, m], t, q, v, p)
        sparse = _c_call(lib, "c_dynamics_sparse", [n, n, int(PTR[-1]), m, m], t, q, v, p)
        for w, g in zip(want, got):
            np.testing.assert_allclose(g, w, rtol=1e-13, atol=1e-13, equal_nan=True)
        nonzeros = [want[2][j, IDX[k]] for j in range(m) for k in range(PTR[j], PTR[j + 1])]
        np.testing.assert_allclose(sparse[0], np.diag(want[0]), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(sparse[2], nonzeros, rtol=1e-13, atol=1e-13)
        c_constraints = _c_call(lib, "c_constraints", [m, (m, n), m], t, q, p)
        for w, g in zip(ns.constraints(t, q, p), c_constraints):
            np.testing.assert_allclose(g, w, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(
            _c_call(lib, "c_energy", [2], t, q, v, p)[0], ns.energy(t, q, v, p), rtol=1e-13
        )
        np.testing.assert_allclose(
            _c_call(lib, "c_restitution", [m], t, q, p)[0],
            ns.restitution(t, q, p),
            rtol=1e-13,
            equal_nan=True,
        )


@needs_cc
def test_the_library_is_built_once_and_a_failing_compiler_is_no_error(tmp_path, monkeypatch):
    _, c_source = _compiled(chain_toml(2))
    _, _, first = load(c_source, tmp_path)
    _, _, second = load(c_source, tmp_path)
    assert (first, second) == ("compiled", "loaded")
    assert len(list(tmp_path.glob("lamech_c_*.so"))) == 1
    assert not list(tmp_path.glob(".build-*"))  # nothing left behind
    monkeypatch.setenv("LAMECH_CC", "none")
    assert compiler() is None
    monkeypatch.setenv("LAMECH_CC", "false")  # a command that fails
    with pytest.raises(CompileFailed):
        load(c_source + "\n", tmp_path)


@needs_cc
def test_the_engine_runs_the_c_functions_with_scipys_numbers():
    """The lecture's cylinder on the engine in C, its functions the compiled C: the same
    events and states as SciPy's path."""
    text = example_path("cylinder").read_text(encoding="utf-8")
    ns = compile_system(lamech.loads(text), jit=True)
    assert ns.jit and ns.jit_cache in ("compiled", "loaded")
    a = simulate(lamech.loads(text), 6.0, jit=False, initial={"theta1": 0.01})
    b = simulate(ns, 6.0, initial={"theta1": 0.01})
    assert a.engine == "SciPy DOP853" and b.engine == "loop (C)"
    assert [e.kind for e in a.events] == [e.kind for e in b.events] == ["slip", "lift-off"]
    assert max(abs(x.t - y.t) for x, y in zip(a.events, b.events)) <= 1e-10
    assert np.max(np.abs(a.q - b.q)) <= 1e-10
    assert np.nanmax(np.abs(a.lambdas - b.lambdas)) <= 1e-9


@needs_cc
def test_a_failing_compiler_runs_the_system_on_scipy(monkeypatch):
    """No usable compiler: the system runs, on SciPy's path, with no error."""
    monkeypatch.setenv("LAMECH_CC", "none")
    ns = compile_system(lamech.load("pendulum"), jit=True)
    assert not ns.jit and ns.jit_cache == ""
    assert simulate(ns, 0.5, samples=3).engine == "SciPy DOP853"
