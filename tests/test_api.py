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


# ----- the options object: one home for how a run integrates ------------------------
def test_options_are_public_and_check_themselves():
    opts = lamech.Options(rtol=1e-9, samples=5)
    assert lamech.numeric.Options is lamech.Options
    with pytest.raises(lamech.SimulationError, match=r"rtol must be in \(0, 1\) \(got 2"):
        lamech.Options(rtol=2.0)
    with pytest.raises(lamech.SimulationError, match="give samples or dt, not both"):
        lamech.Options(samples=5, dt=0.1)
    with pytest.raises(lamech.SimulationError, match="engine must be one of auto, compiled"):
        lamech.Options(engine="fast")
    assert issubclass(lamech.SimulationError, lamech.LamechError)
    assert opts.samples == 5 and opts.atol == lamech.Options().atol


def test_simulate_takes_options_and_the_older_keywords_replace_their_fields():
    pendulum = lamech.load("pendulum")
    opts = lamech.Options(samples=5, rtol=1e-9)
    by_object = lamech.simulate(pendulum, 1.0, options=opts)
    by_keywords = lamech.simulate(pendulum, 1.0, samples=5, rtol=1e-9)
    assert by_object.t.tolist() == by_keywords.t.tolist() == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert (by_object.q == by_keywords.q).all()
    both = lamech.simulate(pendulum, 1.0, options=opts, samples=3)  # the keyword wins
    assert len(both.t) == 3
    with pytest.raises(TypeError, match="simulate: unknown option 'sample'; the options are"):
        lamech.simulate(pendulum, 1.0, sample=3)


def test_sweep_takes_options_and_refuses_those_of_simulate_only():
    kw = dict(t_end=2.7, initial={"theta1": 0.01})
    res = lamech.sweep("cylinder", {"mu": [0.3]}, "slip", options=lamech.Options(samples=11), **kw)
    old = lamech.sweep("cylinder", {"mu": [0.3]}, "slip", samples=11, **kw)
    assert res.column("slip:t").tolist() == old.column("slip:t").tolist()
    with pytest.raises(lamech.SweepError, match="a sweep samples its runs by samples, not dt"):
        lamech.sweep("cylinder", {"mu": [0.3]}, "slip", options=lamech.Options(dt=0.1), **kw)
    with pytest.raises(lamech.SweepError, match="rtol must be in"):
        lamech.sweep("cylinder", {"mu": [0.3]}, "slip", rtol=5.0, **kw)
    with pytest.raises(TypeError, match="sweep: unknown option 'worker'"):
        lamech.sweep("cylinder", {"mu": [0.3]}, "slip", worker=1, **kw)


def test_the_command_line_reads_the_options_help_and_choices_from_options():
    import dataclasses

    fields = {f.name: f for f in dataclasses.fields(lamech.Options)}
    text = _help("simulate")
    assert fields["atol"].metadata["help"] in text
    assert "{" + ",".join(fields["method"].metadata["choices"]) + "}" in text
    assert "{" + ",".join(fields["engine"].metadata["choices"]) + ",loop}" in text
    assert "{" + ",".join(fields["engine"].metadata["choices"]) + ",simulate}" in _help("sweep")


def _help(command: str) -> str:
    import contextlib
    import io

    from lamech.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        main([command, "--help"])
    return " ".join(out.getvalue().split())
