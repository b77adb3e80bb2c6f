"""Steady motions of a problem whose constraints move: a chart in which it is autonomous.

A bead on a hoop spun about the vertical at the rate w, written in Cartesian
coordinates (the sphere x^2 + y^2 + z^2 = R^2 and the turning plane
y cos(wt) - x sin(wt) = 0), has equations with t in them: no configuration is at rest.
Its steady motions (the bead riding on the turning hoop at cos(theta) = g/(R w^2)) are
equilibria of the same problem in the hoop's own angle,
x = R sin(theta) cos(wt), y = R sin(theta) sin(wt), z = -R cos(theta): a chart that
satisfies both constraints identically and in which the reduced Lagrangian has no
explicit t (a relative equilibrium: at rest in the turning frame).

:func:`autonomous_chart` looks for such a chart by a rule that knows no hoops:

1. Angles for every holonomic constraint that is a circle or a sphere
   (:func:`~lamech.model.circle_chart`: r = c + R (sin(theta) cos(phi),
   sin(theta) sin(phi), -cos(theta))).
2. Each other holonomic constraint on the charted coordinates only, written in those
   angles, is solved for one of them among the values its own terms offer: for an angle
   s, each argument a (free of s) of a sine or cosine in it gives s = a, a + pi, -a and
   pi - a. The turning plane becomes R sin(theta) sin(phi - wt) = 0: phi = wt. A value
   is kept when the constraint then vanishes identically (at random points, as
   :func:`~lamech.model._chart.chart_issues` checks a chart).
   Where no constraint is a circle or a sphere, a line through the origin that turns
   with t (a(t) x + b(t) y = 0) gets polar coordinates x = r cos(phi), y = r sin(phi)
   first, and the same step solves it for phi (a bead on a wire turned at W: phi = Wt).
3. The chart is used when :func:`~lamech.model.with_chart` accepts it: every holonomic
   constraint on the charted coordinates holds identically
   (:func:`~lamech.model._chart.chart_issues`) and the initial state is reached.

Whether the chart takes t out is for the caller to see (:func:`~._modes.modes` solves
the charted problem and keeps it only if its reduced equations have no t). A sign
choice (phi = wt rather than wt + pi) loses nothing: the polar angle of the chart runs
over (-pi, pi], so its negative half is the other side of the hoop.
"""

from __future__ import annotations

import itertools

import sympy as sp

from ..model import ModelError, System, circle_chart, with_chart
from ..model._chart import ChartProposal, _random_points, _vanishes

__all__ = ["autonomous_chart", "complete_chart", "file_state"]


def autonomous_chart(system: System) -> System | None:
    """``system`` in the angles of its circles and spheres with every other holonomic
    constraint on them solved (module docstring), or None where there is no such chart
    (no circle or sphere, a constraint no angle solves, the file has a chart already)."""
    if system.chart is not None:
        return None
    proposal = circle_chart(system) or _turning_line(system)
    if proposal is None:
        return None
    return complete_chart(system, proposal)


def _turning_line(system: System) -> ChartProposal | None:
    """Polar coordinates (x = r cos(phi), y = r sin(phi)) for the two coordinates of the
    first holonomic constraint that moves with t and is linear and homogeneous in them,
    a(t) x + b(t) y = 0: a line through the origin turning with t (a bead on a wire
    turned at W: x sin(Wt) - y cos(Wt) = 0), which :func:`complete_chart` then solves for
    phi (phi = Wt), leaving the distance r along the line, of either sign."""
    coords = {c.symbol: c.name for c in system.coordinates}
    names = set(coords.values()) | {p.name for p in system.parameters}
    for con in system.constraints:
        f = con.expr
        inside = sorted(f.free_symbols & set(coords), key=str)
        if not con.holonomic or not f.has(system.t) or len(inside) != 2:
            continue
        x, y = inside
        a, b = sp.diff(f, x), sp.diff(f, y)
        if (a.free_symbols | b.free_symbols) & set(coords) or sp.expand(f - a * x - b * y) != 0:
            continue
        r, phi = f"r{con.name}", f"phi{con.name}"
        if {r, phi} & names:
            continue
        R, P = sp.Symbol(r, real=True), sp.Symbol(phi, real=True)
        return ChartProposal((), (r, phi), ((coords[x], R * sp.cos(P)), (coords[y], R * sp.sin(P))))
    return None


def complete_chart(system: System, proposal: ChartProposal) -> System | None:
    """``system`` with the chart ``proposal``, after solving each holonomic constraint
    that it does not satisfy, and that is on its coordinates only, for one of its angles
    (module docstring, step 2); None where one is left unsolved or the chart is refused."""
    coords = {c.name: c.symbol for c in system.coordinates}
    angles = [sp.Symbol(n, real=True) for n in proposal.coordinates]
    sub = {coords[name]: e for name, e in proposal.map}
    used = list(proposal.constraints)
    pv = system.parameter_values
    for con in system.constraints:
        if not con.holonomic or con.name in used:
            continue
        inside = con.expr.free_symbols & set(coords.values())
        if not inside or not inside <= set(sub):
            continue  # on coordinates the chart leaves: it stays a constraint
        g = con.expr.xreplace(sub)
        points = _random_points(sorted(g.free_symbols - set(pv), key=str), pv, 3, 43)
        if _vanishes(g, points)[0]:
            used.append(con.name)
            continue
        solved = _solve_for_angle(g, [a for a in angles if g.has(a)], points)
        if solved is None:
            return None
        s, value = solved
        sub = {k: e.xreplace({s: value}) for k, e in sub.items()}
        angles.remove(s)
        used.append(con.name)
    if not angles:
        return None  # nothing left to move: not a chart of a motion
    by_symbol = {c.symbol: c.name for c in system.coordinates}
    completed = ChartProposal(
        tuple(used),
        tuple(a.name for a in angles),
        tuple((by_symbol[k], e) for k, e in sub.items()),
    )
    try:
        return with_chart(system, completed)
    except ModelError:
        return None


def _solve_for_angle(g: sp.Expr, angles: list[sp.Symbol], points) -> tuple | None:
    """(s, value): an angle s and a value (free of s) that make g vanish identically,
    from the values g's own sines and cosines offer (module docstring, step 2); the last
    angle first (the azimuth of a sphere before its polar angle). None if none does."""
    for s in reversed(angles):
        arguments = {
            f.args[0]
            for f in g.atoms(sp.sin, sp.cos)
            if not f.args[0].has(s) and f.args[0].free_symbols
        }
        for a, shift in itertools.product(sorted(arguments, key=sp.default_sort_key), range(4)):
            value = (a, a + sp.pi, -a, sp.pi - a)[shift]
            if _vanishes(g.xreplace({s: value}), points)[0]:
                return s, value
    return None


def file_state(system: System, state: dict[str, float], t: float = 0.0) -> dict[str, float]:
    """``state`` ({coordinate or ``x'``: value}, in a chart's coordinates where the
    system has a chart) in the file's coordinates and velocities at time t: each
    parametrised coordinate from the chart's map, its velocity d/dt of the map (the
    turning hoop's bead moves with it at rest in the chart); the others as given. For
    ``lamech simulate --mode``, which runs in the file's coordinates."""
    chart = system.chart
    if chart is None or not all(c.name in state for c in chart.coordinates):
        return dict(state)  # in the file's coordinates already (lamech's own chart)
    pv = system.parameter_values
    env: dict = {**pv, system.t: t}
    for c in (*system.chart_coordinates, *system.coordinates):
        if c.name in state:
            env[c.symbol] = state[c.name]
        env[c.velocity] = state.get(c.name + "'", 0.0)
    own = {c.name for c in chart.coordinates}
    out = {k: v for k, v in state.items() if k.rstrip("'") not in own}
    for s, e in chart.map:
        name = next(c.name for c in system.coordinates if c.symbol == s)
        rate = sp.diff(e, system.t) + sum(
            (sp.diff(e, c.symbol) * c.velocity for c in system.chart_coordinates), sp.Integer(0)
        )
        out[name] = float(sp.N(e.xreplace(env)))
        out[name + "'"] = float(sp.N(rate.xreplace(env)))
    return out
