"""Bounds of the symbolic path, counted in work, never in time.

A solve runs under one :class:`~lamech.symbolic._work.Work` budget
(:func:`~lamech.symbolic._work.work_budget`): the normal forms of
:mod:`lamech.symbolic._normal` charge it by the size of the polynomials they build, and
every other SymPy call on the path is bounded by the size of its input (operation counts,
:func:`count_ops`). Nothing depends on a clock, so the same file and options give the
same bytes on an idle or a loaded machine, in the main thread or any other.

:func:`within` runs one step that may give up (:class:`OverBudget`) and returns its
fallback, the expression as it was, when it does.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import sympy as sp

from ._work import OverBudget

__all__ = ["within", "count_ops"]

T = TypeVar("T")


def within(fn: Callable[..., T], *args: Any, fallback: T) -> T:
    """``fn(*args)``, or ``fallback`` when it runs out of work (:class:`OverBudget`)."""
    try:
        return fn(*args)
    except OverBudget:
        return fallback


@functools.lru_cache(maxsize=4096)
def _count(expr: Any) -> int:
    return int(sp.count_ops(expr))


EXACT_NODES = 3000
"""Expressions of up to this many nodes are counted by ``sympy.count_ops``; larger ones
by their number of nodes (about the same; ``count_ops`` costs seconds on a closed form
of a million operations, which is only ever compared with a bound)."""


def count_ops(expr: Any) -> int:
    """``sympy.count_ops(expr)`` for expressions of up to :data:`EXACT_NODES` nodes, their
    node count beyond; remembered: a solve asks it of the same long closed forms again
    and again (to decide what is simplified and what is printed)."""
    expr = sp.sympify(expr)
    if expr.is_Atom:
        return 0
    if not isinstance(expr, sp.Basic):  # a matrix
        return int(sp.count_ops(expr))
    try:
        return _count_or_nodes(expr)
    except TypeError:  # unhashable: count it afresh
        return int(sp.count_ops(expr))


@functools.lru_cache(maxsize=4096)
def _count_or_nodes(expr: Any) -> int:
    nodes = 0
    stack = [expr]
    while stack:
        e = stack.pop()
        nodes += 1
        if nodes > EXACT_NODES:
            return tree_size(expr)
        stack.extend(e.args)
    return _count(expr)


def tree_size(root: sp.Basic) -> int:
    """The number of nodes of ``root`` as a tree, counted over its graph: each shared
    subexpression is sized once (a mechanism's closed forms repeat the same parts
    thousands of times: 9 million nodes as a tree, a few thousand objects)."""
    size: dict[int, int] = {}
    stack: list[tuple[sp.Basic, bool]] = [(root, False)]
    while stack:
        e, done = stack.pop()
        key = id(e)
        if key in size:
            continue
        if done:
            size[key] = 1 + sum(size[id(a)] for a in e.args)
        else:
            stack.append((e, True))
            stack.extend((a, False) for a in e.args if id(a) not in size)
    return size[id(root)]


def graph_symbols(exprs) -> set:
    """The free symbols of ``exprs``, found by visiting each shared subexpression once
    (SymPy's ``free_symbols`` walks the tree: minutes on a four-bar's forces)."""
    seen: set[int] = set()
    out: set = set()
    stack = [sp.sympify(e) for e in exprs if e is not None]
    while stack:
        e = stack.pop()
        if id(e) in seen:
            continue
        seen.add(id(e))
        if e.is_Symbol:
            out.add(e)
        stack.extend(e.args)
    return out
