"""The Python API's faces: the top level and each sub-package export their names without
a warning; a name a face no longer exports (plumbing, or renamed) still resolves, from
the module that defines it, with a DeprecationWarning saying where it lives."""

from __future__ import annotations

import importlib
import warnings

import pytest

import lamech

FACES = ["lamech", "lamech.symbolic", "lamech.numeric", "lamech.present", "lamech.problem"]
FACES += ["lamech.sweeps"]


@pytest.mark.parametrize("package", FACES)
def test_every_name_a_face_exports_resolves_without_a_warning(package):
    module = importlib.import_module(package)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in module.__all__:
            assert getattr(module, name) is not None, name


@pytest.mark.parametrize(
    "package, name, home",
    [
        ("lamech.symbolic", "tidy", "_reduce"),
        ("lamech.symbolic", "kkt_numeric", "_derive"),
        ("lamech.numeric", "check_options", "_options"),
        ("lamech.numeric", "EVENT_FALLBACKS", "_batch:FALLBACKS"),
        ("lamech.present", "sweep_html", "_notebook"),
        ("lamech.problem", "as_system", "_coerce"),
        ("lamech.sweeps", "SweepRun", "_result:SweepResult"),
        ("lamech.sweeps", "parse_values", "_parse"),
    ],
)
def test_a_name_that_left_a_face_warns_and_says_where_it_lives(package, name, home):
    module, _, attr = home.partition(":")
    module = f"{package}.{module}"  # its private module
    where = f"{module}.{attr or name}"
    with pytest.warns(DeprecationWarning, match=rf"{package}\.{name} is deprecated: .*\({where}\)"):
        value = getattr(importlib.import_module(package), name)
    assert value is getattr(importlib.import_module(module), attr or name)
    assert name not in importlib.import_module(package).__all__


def test_a_name_no_face_ever_had_is_an_attribute_error():
    with pytest.raises(AttributeError, match="module 'lamech.symbolic' has no attribute 'nope'"):
        lamech.symbolic.nope  # noqa: B018


def test_run_sweep_is_the_one_deprecated_top_level_name():
    assert "sweep" in lamech.__all__ and "SweepResult" in lamech.__all__
    assert "run_sweep" not in lamech.__all__
    assert lamech.run_sweep is lamech.sweeps.run_sweep  # still there; warns when called
