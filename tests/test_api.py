"""The Python API's faces: the top level and each sub-package export their names without
a warning; a name a face no longer exports (plumbing, or renamed) still resolves, from
the module that defines it, with a DeprecationWarning saying where it lives. Misuse is
answered with what to pass: a problem of the wrong type, values the command line refuses."""

from __future__ import annotations

import importlib
import math
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


# ----- the Python API answers misuse with what to pass -----------------------------------
@pytest.mark.slow
def test_a_problem_may_be_named_by_its_file_or_example_in_every_api_function(tmp_path):
    by_name = lamech.solve("pendulum")
    assert by_name.multipliers == lamech.solve(lamech.load("pendulum")).multipliers
    path = tmp_path / "p.toml"
    path.write_text(lamech.problem.example_path("pendulum").read_text(), encoding="utf-8")
    assert lamech.solve(path).multipliers == by_name.multipliers
    a = lamech.simulate("pendulum", 0.2, samples=3)
    b = lamech.simulate(lamech.load("pendulum"), 0.2, samples=3)
    assert a.status == "ok" and (a.q == b.q).all()
    assert [e.stability for e in lamech.modes("pendulum").equilibria] == ["stable", "unstable"]
    with pytest.raises(ValueError, match=r"lamech\.loads\(text\)"):
        lamech.solve(path.read_text())


@pytest.mark.parametrize(
    "call, argument",
    [
        (lambda: lamech.solve(None), "solve: system"),
        (lambda: lamech.solve(42), "solve: system"),
        (lambda: lamech.modes(None), "modes: problem"),
        (lambda: lamech.simulate(None, 1.0), "simulate: system"),
        (lambda: lamech.sweep(None, {"l": [1.0]}, t_end=0.1), "sweep: problem"),
        (lambda: lamech.dynamics(None), "dynamics: system"),
        (lambda: lamech.multipliers(None), "multipliers: system"),
    ],
)
def test_a_problem_of_the_wrong_type_is_a_type_error_naming_the_argument(call, argument):
    with pytest.raises(TypeError, match=argument + r" must be a lamech.System \(lamech.load"):
        call()


@pytest.mark.parametrize(
    "params, message",
    [
        ({"g": math.nan}, r"params\['g'\] must be a finite number, got nan"),
        ({"l": math.inf}, r"params\['l'\] must be a finite number"),
        ({"g": "x"}, r"params\['g'\] must be a number, got 'x'"),
        ({"l": 0}, "parameter `l` is 1 in the file and its sign is part of the derivation"),
        ({"m": -1}, "parameter `m` is 1 in the file and its sign is part of the derivation"),
    ],
)
def test_simulate_refuses_the_parameter_values_the_command_line_refuses(params, message):
    with pytest.raises(lamech.SimulationError, match=message):
        lamech.simulate(lamech.load("pendulum"), 1.0, params=params)


def test_a_compiled_systems_parameters_keep_their_signs():
    ns = lamech.compile_system(lamech.load("cylinder"))
    with pytest.raises(lamech.SimulationError, match=r"params\['m'\] = -1: `m` is 1 in the file"):
        lamech.simulate(ns, 1.0, params={"m": -1.0})
    with pytest.raises(lamech.SimulationError, match="a coefficient of friction is >= 0"):
        lamech.simulate(lamech.load("cylinder"), 1.0, params={"mu": -0.1})
    assert lamech.simulate("cylinder", 0.1, samples=3, params={"mu": 0.0}).status == "ok"


@pytest.mark.parametrize(
    "at, error, message",
    [
        ({"theta": math.nan}, ValueError, r"at\['theta'\] must be a finite number, got nan"),
        ({"theta": "pi"}, ValueError, r"at\['theta'\] must be a real number, got 'pi'"),
        ([0.1], TypeError, r"at must be a dict \{coordinate: value\}"),
    ],
)
def test_modes_at_must_be_finite_numbers_by_name(at, error, message):
    with pytest.raises(error, match=message):
        lamech.modes(lamech.load("pendulum"), at=at)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"samples": 10**9}, "samples=1000000000: more output times than lamech keeps"),
        ({"dt": 1e-10}, "dt=1e-10 gives 1e[+]10 samples: more output times than lamech keeps"),
    ],
)
def test_more_samples_than_memory_holds_are_refused_before_the_run(options, message):
    with pytest.raises(lamech.SimulationError, match=message):
        lamech.simulate(lamech.load("pendulum"), 1.0, **options)


def test_a_sweeps_single_measure_may_be_a_string():
    kw = {"t_end": 0.6, "samples": 3, "workers": 1, "progress": False,
          "initial": {"theta1": 0.01}}  # fmt: skip
    one = lamech.sweep("cylinder", {"mu": [0.5]}, "liftoff", **kw).rows
    listed = lamech.sweep("cylinder", {"mu": [0.5]}, ["liftoff"], **kw).rows
    assert list(one[0]) == list(listed[0]) and "liftoff:t" in one[0]
    assert one[0]["status"] == listed[0]["status"] == "ok"
    with pytest.raises(TypeError, match="sweep: params must be a dict"):
        lamech.sweep("cylinder", [("mu", 0.5)], "liftoff", **kw)
