"""Test-wide setup: compiled systems are cached in this run's temporary folders, never in
the user's ~/.cache, so a clean machine (CI) and a developer's one behave the same.

A test never sees a compiled form another test left in a cache: ``simulate``'s default
(``jit=None``) loads a problem's compiled C from the cache where it is there, so a shared
cache made what a test sees of the cache depend on which tests ran before it on the same
worker (issue 28 item 1). Each test has a folder of its own; only the tests marked
``shared_cache`` (the ones that compile, and ask for their engine) share
one per run, so a system one of them compiled is loaded by the others. ``slow`` says only
that a test is left out of the default set (``-m "not slow"``); CI runs it all the same."""

from __future__ import annotations

import os
import shutil

import pytest

# Parametrized cases left out of the default set (`-m "not slow"`): each took 2 s or more
# in a default run under load (about 1 s idle), mostly SymPy solving a bundled example or a
# peer's model, or a server or a subprocess. Every test keeps at least one case in the
# default set; CI (`./run-tests`) runs them all. Whole tests are marked where they stand.
# By test, its cases' ids:
SLOW_CASES = {
    "test_bad_input.py::test_bad_file": {
        "120-angular-velocity-unknown-body",
        "121-angular-velocity-unknown-component",
        "122-angular-velocity-in-f",
        "123-angular-velocity-rate",
    },
    "test_bench.py::test_b9s_sympy_script_runs_and_prints_a_multiplier_per_constraint": {
        "atwood",
    },
    "test_cc.py::test_the_c_functions_give_the_generated_pythons_numbers": {
        "double_pendulum",
        "incline_disk",
        "moving_support",
        "heavy_top",
    },
    "test_core.py::test_chain_tensions_at_rest_against_statics": {
        "2",
    },
    "test_core.py::test_json_expressions_parse_back": {
        "cylinder",
        "double_atwood",
        "hoop_bead",
    },
    "test_examples.py::test_example_loads_and_is_consistent": {
        "atwood",
        "atwood_pulley",
        "cylinder",
        "double_atwood",
        "hoop_bead",
        "incline_disk",
        "ladder",
        "moving_support",
        "rotating_table",
        "sphere_slide",
        "spherical_pendulum",
        "wedge",
    },
    "test_examples.py::test_listed_integrals_are_conserved": {
        "hoop_bead",
        "ladder",
        "moving_support",
        "spherical_pendulum",
        "wedge",
    },
    "test_impossible_inputs.py::test_min_and_max_of_many_arguments_do_not_recurse": {
        "16",
    },
    "test_loop.py::test_the_loop_applies_impacts_contacts_and_the_zeno_accumulation_itself": {
        "incline",
        "zeno ball",
        "zeno slip",
    },
    "test_loop.py::test_the_loop_gives_simulates_events_samples_and_forces": {
        "cylinder",
        "four_bar",
        "knife_edge",
        "ladder",
        "pendulum",
        "reversal",
        "stick",
        "wedge",
    },
    "test_multipliers.py::test_raw_multipliers_solve_the_kkt_system": {
        "andrews_squeezer",
        "heavy_top",
    },
    "test_readable.py::test_the_printed_form_is_the_textbooks": {
        "hoop_bead: the hoop's normal force",
        "incline_disk: friction on a rolling disk",
        "spherical_pendulum: string tension",
        "spherical_pendulum: tension on the shell",
        "wedge: normal force on the block",
    },
    "test_rolling.py::test_the_rolling_disc_accelerates_as_sympys_kanes_method_says": {
        "rolling_disc",
    },
    "test_serve_http.py::test_malformed_requests_are_4xx_with_a_message": {
        '{"text": "x", "simulate": true, "t_end": 1, "initial": [1]}-initial',
        '{"text": "x", "simulate": true, "t_end": 1, "initial": {"theta1": "0.1"}}-finite',
        '{"text": "x", "simulate": true, "t_end": NaN}-t_end',
    },
    "test_serve_http.py::test_work_takes_json_only": {
        "None",
        "multipart/form-data; boundary=x",
        "text/plain",
    },
    "test_simulate.py::test_generated_code_matches_sympy": {
        "four_bar",
        "heavy_top",
        "hoop_bead",
        "moving_support",
        "rolling_disc",
        "rolling_sphere",
        "spherical_pendulum",
    },
    "test_steps.py::test_every_examples_steps_hold_together": {
        "atwood_pulley",
        "cylinder",
        "double_atwood",
        "hoop_bead",
        "incline_disk",
        "knife_edge",
        "ladder",
        "pendulum",
        "rotating_table",
        "sphere_slide",
        "spherical_pendulum",
        "wedge",
    },
    "test_trust.py::test_a_ball_bouncing_many_times_comes_to_rest_on_the_floor": {
        "1e-06",
        "1e-08",
        "1e-10",
    },
    "test_trust.py::test_a_constant_positive_multiplier_never_lets_go": {
        "wedge-contact-<lambda>",
    },
    "test_trust.py::test_no_bundled_example_passes_through_a_surface_it_names": {
        "andrews_squeezer",
        "double_pendulum",
        "four_bar",
        "heavy_top",
        "hoop_bead",
        "moving_support",
        "rolling_disc",
        "spherical_pendulum",
    },
    "test_trust3.py::test_a_parameters_name_as_an_initial_value_is_its_value": {
        "command1-theta=l-theta=1",
    },
    "test_trust3.py::test_the_cart_pendulum_hangs_stably_and_is_unstable_inverted": {
        "3.0-0.5-0.7-True",
    },
}


COLLECTED = pytest.StashKey[dict]()
"""The cases this process collected, by test (``SLOW_CASES``'s keys and ids), before
``-m`` or ``-k`` deselected any: what tests/test_slow_cases.py checks the list against."""


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Mark the cases in ``SLOW_CASES`` slow (before ``-m`` deselects by marker), and
    keep the ids collected (``COLLECTED``)."""
    collected: dict[str, set] = {}
    for item in items:
        test, _, case = item.nodeid.removeprefix("tests/").partition("[")
        collected.setdefault(test, set()).add(case[:-1])
        if case[:-1] in SLOW_CASES.get(test, ()):
            item.add_marker(pytest.mark.slow)
    config.stash[COLLECTED] = collected


@pytest.fixture(scope="session")
def slow_cases_collected(request):
    """(``SLOW_CASES``, the cases collected by test, the files collected whole): the
    files named with ``::`` on the command line, or all under ``--lf``, were collected in
    part only, so their tests' absence says nothing."""
    config = request.config
    collected = config.stash.get(COLLECTED, {})
    files = {test.partition("::")[0] for test in collected}
    if config.getoption("lf", False) or config.getoption("failedfirst", False):
        files = set()
    for arg in config.args:
        if "::" in arg:
            files.discard(os.path.basename(arg.partition("::")[0]))
    return SLOW_CASES, collected, files


@pytest.fixture(scope="session")
def shared_cache_dir(tmp_path_factory):
    """One folder per run, shared by pytest-xdist's workers (the parent of a worker's
    base folder): the compiled forms of the tests marked ``shared_cache``."""
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent
    return base / "lamech-cache"


@pytest.fixture(scope="session", autouse=True)
def fixtures_cache_dir(tmp_path_factory):
    """``LAMECH_CACHE_DIR`` for the session's and modules' fixtures, which run before
    any test's own: a folder of this worker's (each test then has its own, below)."""
    path = tmp_path_factory.mktemp("lamech-cache-fixtures")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LAMECH_CACHE_DIR", str(path))
        yield path


@pytest.fixture(autouse=True)
def lamech_cache_dir(request, tmp_path_factory, shared_cache_dir):
    """``LAMECH_CACHE_DIR`` for the test and the processes it starts: a new folder for
    each test, the run's shared one for a test marked ``shared_cache``."""
    if request.node.get_closest_marker("shared_cache") is not None:
        path = shared_cache_dir
    else:
        path = tmp_path_factory.mktemp("lamech-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LAMECH_CACHE_DIR", str(path))
        yield path


@pytest.fixture(scope="session")
def solved_example():
    """``solved_example(name)``: ``lamech.solve`` of a bundled example, solved once per
    worker and shared by the tests that read it (a Solution is frozen)."""
    import lamech

    cache = {}

    def solved(name: str):
        if name not in cache:
            cache[name] = lamech.solve(lamech.load(name))
        return cache[name]

    return solved


@pytest.fixture(scope="module")
def chromium():
    """A headless Chromium driven by Playwright (Debian's browser: ``apt-get install
    chromium``; .ci/run installs it), or a skip that says what is missing."""
    sync = pytest.importorskip("playwright.sync_api", reason="playwright not installed")
    path = next((p for p in map(shutil.which, ("chromium", "chromium-browser")) if p), None)
    if path is None:
        pytest.skip("no Chromium on this machine (Debian: apt-get install chromium)")
    with sync.sync_playwright() as p:
        # the flags that keep Chromium off the network (this machine's is closed)
        browser = p.chromium.launch(
            executable_path=path,
            args=[
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
            ],
        )
        try:
            yield browser
        finally:
            browser.close()
