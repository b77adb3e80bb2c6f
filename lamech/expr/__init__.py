"""Safe expressions: problem-file text to SymPy, and SymPy back to problem-file text.

The grammar (the only thing a problem file may contain in an expression):
numbers, declared names, ``t``, ``x'`` for the velocity of coordinate ``x`` (``x''``
for its acceleration in printed equations), ``+ - * / ^ **``, parentheses, the
functions in :data:`FUNCTIONS` and ``pi``; and ``body.wx`` (a dotted name: a body's
angular velocity component, see :func:`parse`).

User text is never handed to ``eval``, ``sympify`` or ``parse_expr``: Python's own
tokenizer-free ``ast`` parses it (after two purely lexical rewrites, ``'`` suffixes and
``^``), and a whitelist walk builds the SymPy expression node by node. Size, nesting
and exponents are bounded *before* anything is built, so hostile text (``9^9^9^9``,
ten thousand parentheses) fails fast with :class:`ExpressionError`. What each node
*builds* is bounded too, since SymPy evaluates as it goes: exact numbers by their
digits (not their magnitude: ``1.0000001^1000000000`` is small but has 7e9 digits),
powers of non-numbers by their exponent after SymPy has combined them (``x^64*x`` is
``x^65``, so what :func:`to_text` prints always parses back), constants by their
magnitude and realness (``exp(exp(20))``, ``asin(2)``), and expressions by the number of
terms they would expand to (``(a + b + c + d + e)^64``).

The modules, each importing only those after it: :mod:`._parse` (the text's checks and
:func:`parse`), :mod:`._build` (the whitelist walk), :mod:`._bounds` (sizes of numbers
and of expansions, the zero test), :mod:`._inputs` (the inputs' vocabulary: :class:`Table`,
:func:`switch_form`, :func:`not_differentiable`), :mod:`._print` (:func:`to_text`,
:func:`latex`, :func:`printable`), :mod:`._units` (quantities with units, ``"30 cm"``,
converted to SI, and :class:`Dimension`) and :mod:`._grammar` (the limits, the functions,
:class:`ExpressionError`). Import the names from here.
"""

from __future__ import annotations

from ._grammar import (
    FUNCTIONS,
    INPUTS,
    MAX_DEPTH,
    MAX_INT_EXPONENT,
    MAX_LENGTH,
    MAX_NUMBER_DIGITS,
    MAX_TERMS,
    RESERVED,  # noqa: F401 (not in __all__; the package checks declared names against it)
    ExpressionError,
    TimeDerivative,
    acceleration_name,
    velocity_name,
)
from ._inputs import (
    Table,
    is_table,
    not_differentiable,
    switch_form,
    table_form,
    table_knots,
    tabulated,
)
from ._parse import parse
from ._print import latex, printable, to_text
from ._units import (
    Dimension,
    Quantity,
    as_quantity,
    is_angle_unit,
    is_quantity,
    quantity,
    spelled_hint,
    spelled_names,
    unit,
)

__all__ = [
    "ExpressionError",
    "FUNCTIONS",
    "parse",
    "to_text",
    "velocity_name",
    "acceleration_name",
    "MAX_LENGTH",
    "MAX_DEPTH",
    "MAX_INT_EXPONENT",
    "MAX_NUMBER_DIGITS",
    "MAX_TERMS",
    "TimeDerivative",
    "printable",
    "not_differentiable",
    "INPUTS",
    "latex",
    "switch_form",
    "tabulated",
    "Table",
    "is_table",
    "table_form",
    "table_knots",
    "Dimension",
    "Quantity",
    "is_quantity",
    "is_angle_unit",
    "as_quantity",
    "spelled_names",
    "spelled_hint",
    "quantity",
    "unit",
]
