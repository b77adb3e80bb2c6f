"""DOP853's tables, SciPy's own coefficients, as the compiled loops take them
(the engine's ``dop853.c``): read from SciPy's file on first use, without importing
``scipy.integrate``."""

from __future__ import annotations

import functools
import os

import numpy as np

from ._kernels import STAGES as _S  # DOP853's number of stages, checked in _tableau

__all__ = ["_tableau", "_dense_tableau", "_tables"]


@functools.cache
def _dop853():
    """SciPy's module of DOP853 coefficients, without importing ``scipy.integrate`` (0.3-0.5
    s at a sweep's start) where its file can be loaded alone (it imports only NumPy)."""
    import importlib.util
    import sys

    if "scipy.integrate" not in sys.modules:
        try:
            spec = importlib.util.find_spec("scipy")
            where = spec.submodule_search_locations if spec is not None else None
            if where:
                path = os.path.join(list(where)[0], "integrate", "_ivp", "dop853_coefficients.py")
                alone = importlib.util.spec_from_file_location("_lamech_dop853", path)
                if alone is not None and alone.loader is not None:
                    module = importlib.util.module_from_spec(alone)
                    alone.loader.exec_module(module)
                    return module
        except Exception:  # pragma: no cover - an unusual SciPy install: import it
            pass
    from scipy.integrate._ivp import dop853_coefficients

    return dop853_coefficients


@functools.cache
def _tableau():
    """SciPy's DOP853 coefficients (A, B, C, E3, E5), loaded on first use."""
    dop = _dop853()
    assert dop.N_STAGES == _S
    return (
        np.ascontiguousarray(dop.A[:_S, :_S]),
        np.ascontiguousarray(dop.B),
        np.ascontiguousarray(dop.C[:_S]),
        np.ascontiguousarray(dop.E3),
        np.ascontiguousarray(dop.E5),
    )


@functools.cache
def _dense_tableau():
    """DOP853's dense output (scipy's ``_dense_output_impl``): the 3 extra stages
    (A_EXTRA (3, 16), C_EXTRA (3,)) and the interpolator's D (4, 16)."""
    dop = _dop853()
    assert dop.INTERPOLATOR_POWER == 7 and dop.N_STAGES_EXTENDED == _S + 4
    return (
        np.ascontiguousarray(dop.A[_S + 1 :]),
        np.ascontiguousarray(dop.C[_S + 1 :]),
        np.ascontiguousarray(dop.D),
    )


def _tables() -> tuple:
    """DOP853's tables as the loops take them (``tab``: the engine's ``lm_tables``)."""
    return (*_tableau(), *_dense_tableau())
