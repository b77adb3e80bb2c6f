"""First integrals and the energy shell.

The energy function (Jacobi integral) of the reduced Lagrangian L_r(q, q', t),
h = sum q' dL_r/dq' - L_r, is conserved when L_r has no explicit t, no
non-conservative force acts, and every constraint left after elimination does no work
(dF/dt = 0 with F's velocity-free part zero). It equals T + V when the constraints do
not move; otherwise it is the Jacobi integral (the bead on a spinning hoop). A
coordinate that L_r does not contain, on which neither Q^nc nor a remaining constraint
acts, is cyclic: its momentum dL_r/dq' is conserved (Routh).

With one non-cyclic independent coordinate and no remaining constraint, the integrals
fixed at the initial state give q'^2 as a function of q, and each multiplier becomes a
function of configuration alone (the pendulum's tension m g (3 cos th - 2 cos th0)).
"""

from __future__ import annotations

import random
from dataclasses import dataclass

import mpmath
import sympy as sp

from ..expr import switch_form
from ..model import Coordinate
from ._derive import Dynamics
from ._normal import normal
from ._reduce import ClosedForms, Reduction, tidy

__all__ = ["Integrals", "integrals", "Shell", "energy_shell"]


@dataclass(frozen=True)
class Integrals:
    """Conserved quantities in the independent coordinates and velocities.

    ``energy`` is the conserved energy function (None when not conserved);
    ``is_jacobi`` says it differs from T + V (moving constraints). ``momenta`` maps each
    cyclic coordinate's name to its conserved momentum.
    """

    energy: sp.Expr | None
    is_jacobi: bool
    momenta: dict
    reason: str | None  # why the energy is not conserved

    @property
    def conserved(self) -> list[sp.Expr]:
        return ([self.energy] if self.energy is not None else []) + list(self.momenta.values())


def _is_zero(e: sp.Expr) -> bool:
    """Zero test by evaluation at three seeded random points with 30 significant digits
    (a nonzero analytic function vanishes there with probability 0). Exact
    simplification is not used: on the nested radicals of an eliminated chain it takes
    seconds per call, and a numeric zero at random points is as trustworthy."""
    e = sp.sympify(e)
    if e == 0:
        return True
    if e.is_Number:
        return False
    # Inputs that switch (step(t - 1), max(0, -x)) are zero at some points only: each
    # switch becomes a symbol of its own, so that the test covers every branch.
    switches: dict = {}
    e = switch_form(e, lambda s: switches.setdefault(s, sp.Dummy(f"branch{len(switches)}")))
    rng = random.Random(5)
    symbols = sorted(e.free_symbols, key=str)
    terms = sp.Add.make_args(e)
    try:
        f = sp.lambdify(symbols, list(terms), modules="mpmath")
    except Exception:  # noqa: BLE001 - a printer gap: treat as "not shown to be zero"
        return False
    with mpmath.workdps(30):
        for _ in range(3):
            args = [mpmath.mpf(rng.uniform(0.2, 0.6)) for _ in symbols]
            try:
                values = [mpmath.mpc(v) for v in f(*args)]
            except (TypeError, ValueError, ZeroDivisionError):
                return False
            scale = max([1.0] + [float(abs(v)) for v in values])
            if not float(abs(mpmath.fsum(values))) <= 1e-20 * scale:
                return False
    return True


def _remaining(dyn: Dynamics, red: Reduction) -> list[int]:
    return [
        j for j, c in enumerate(dyn.system.constraints) if c.name not in red.eliminated_constraints
    ]


def integrals(dyn: Dynamics, red: Reduction) -> Integrals:
    """Find the energy (or Jacobi) integral and the cyclic momenta; see module docstring."""
    system = dyn.system
    Lr = red.apply(system.L)
    qd = [c.velocity for c in red.independent]
    t = system.t
    rest = _remaining(dyn, red)
    # Generalized non-conservative force on the independent coordinates: J^T Q.
    J = _coordinate_jacobian(system, red)
    Qr = J.T * dyn.Q.applyfunc(red.apply)
    reason = None
    if any(not _is_zero(e) for e in Qr):
        reason = "a non-conservative force acts"
    elif not _is_zero(sp.diff(Lr, t)):
        reason = "the Lagrangian depends on time"
    else:
        qdv = sp.Matrix(system.qd)
        for j in rest:
            Fj = dyn.velocity_forms[j]
            b = red.apply(Fj - (dyn.A[j, :] * qdv)[0])
            if not _is_zero(b):
                reason = f"constraint `{system.constraints[j].name}` moves (does work)"
                break
    energy = None
    jacobi = False
    if reason is None:
        energy = _quadratic_energy(dyn, red, qd)
        if energy is None:
            energy = tidy(sum((v * sp.diff(Lr, v) for v in qd), sp.Integer(0)) - Lr)
        jacobi = not _is_zero(energy - red.apply(system.T + system.V))
    momenta = {}
    A_rest = sp.Matrix([dyn.A[j, :] for j in rest]).applyfunc(red.apply) if rest else None
    for i, c in enumerate(red.independent):
        if Lr.has(c.symbol) and not _is_zero(sp.diff(Lr, c.symbol)):
            continue
        if not _is_zero(Qr[i]):
            continue
        if A_rest is not None and any(not _is_zero(e) for e in (A_rest * J[:, i])):
            continue
        p = tidy(sp.diff(Lr, c.velocity))
        if p != 0:
            momenta[c.name] = p
    return Integrals(energy, jacobi, momenta, reason)


def _quadratic_energy(dyn: Dynamics, red: Reduction, qd: list) -> sp.Expr | None:
    """T + V with T = q'^T M q'/2, each entry of the mass matrix trig-simplified on its
    own, when that is the energy function: nothing eliminated and T quadratic in the
    velocities (sum q' dT/dq' = 2 T). The entries are short, so this costs a tenth of
    ``trigsimp`` on the expanded T (0.4 s on the four-bar linkage and the rolling
    disc), and reads as well."""
    system = dyn.system
    if red.substitution:
        return None
    T = system.T
    if not _is_zero(sum((v * sp.diff(T, v) for v in qd), sp.Integer(0)) - 2 * T):
        return None
    n = len(qd)

    def entry(e: sp.Expr) -> sp.Expr:
        return e if e.is_Number or e.is_Symbol else sp.factor_terms(normal(e))

    def quadratic() -> sp.Expr:
        terms = []
        for i in range(n):
            for j in range(i, n):
                m = dyn.M[i, j]
                if m != 0:
                    w = sp.Rational(1, 2) if i == j else sp.Integer(1)
                    terms.append(w * entry(m) * qd[i] * qd[j])
        return sp.factor_terms(sp.Add(*terms))

    return quadratic() + system.V


def _coordinate_jacobian(system, red: Reduction) -> sp.Matrix:
    """d q_all / d q_independent, shape (n, n_independent), on the constraint manifold."""
    pos = red.position_substitution
    rows = []
    for c in system.coordinates:
        expr = pos.get(c.symbol, c.symbol)
        rows.append([sp.diff(expr, ci.symbol) for ci in red.independent])
    return sp.Matrix(rows) if rows else sp.zeros(0, 0)


@dataclass(frozen=True)
class Shell:
    """The energy shell of a one-degree-of-freedom motion.

    ``coordinate`` is the remaining coordinate, ``speed_squared`` its q'^2 as a function
    of q, ``velocities`` the cyclic velocities as functions of q, ``multipliers`` each
    multiplier on the shell, ``omitted`` why a multiplier is not given.
    """

    coordinate: Coordinate
    speed_squared: sp.Expr
    velocities: dict
    multipliers: dict
    omitted: dict


def energy_shell(
    dyn: Dynamics, red: Reduction, ints: Integrals, forms: ClosedForms
) -> tuple[Shell | None, str | None]:
    """The shell (or None and the reason) from the integrals and the initial state."""
    system = dyn.system
    if ints.energy is None:
        return None, f"no energy integral ({ints.reason})"
    if _remaining(dyn, red):
        return None, "constraints remain after elimination"
    free = [c for c in red.independent if c.name not in ints.momenta]
    if len(free) != 1:
        return None, f"{len(free)} degrees of freedom remain after the cyclic coordinates"
    coord = free[0]
    init = system.initial_state
    cyc = [c for c in red.independent if c.name in ints.momenta]
    vel_sub = {}
    if cyc:
        eqs = [ints.momenta[c.name] - ints.momenta[c.name].subs(init) for c in cyc]
        sol = sp.solve(eqs, [c.velocity for c in cyc], dict=True)
        if len(sol) != 1:
            return None, "the cyclic momenta cannot be solved for the cyclic velocities"
        vel_sub = {k: tidy(v) for k, v in sol[0].items()}
    E = tidy(ints.energy.subs(vel_sub))
    E0 = tidy(ints.energy.subs(init))
    v = coord.velocity
    try:
        poly = sp.Poly(sp.expand(E), v)
    except sp.PolynomialError:
        return None, "the energy is not polynomial in the velocity"
    if poly.degree() != 2 or poly.coeff_monomial(v) != 0:
        return None, "the energy is not quadratic and even in the velocity"
    a = poly.coeff_monomial(v**2)
    c0 = poly.coeff_monomial(1)
    v2 = tidy((E0 - c0) / a)
    multipliers, omitted = {}, {}
    for name, ops in forms.sizes.items():
        if isinstance(name, str):
            omitted[name] = f"its closed form is long ({ops} operations)"
    for name, lam in forms.readable_multipliers.items():
        expr = sp.expand(lam.subs(vel_sub))
        if expr.has(system.t):
            omitted[name] = "it depends on time"
            continue
        try:
            p = sp.Poly(expr, v)
        except sp.PolynomialError:
            omitted[name] = "it is not polynomial in the velocity"
            continue
        if any(k % 2 == 1 and coef != 0 for (k,), coef in p.terms()):
            omitted[name] = "it depends on the sign of the velocity"
            continue
        multipliers[name] = tidy(sum(coef * v2 ** (k // 2) for (k,), coef in p.terms()))
    return Shell(coord, v2, vel_sub, multipliers, omitted), None
