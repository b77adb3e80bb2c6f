"""Test-wide setup: compiled systems are cached in this run's temporary folders, never in
the user's ~/.cache, so a clean machine (CI) and a developer's one behave the same.

A test never sees a compiled form another test left in a cache: ``simulate``'s default
(``jit=None``) loads a problem's compiled C from the cache where it is there, so a shared
cache made what a test sees of the cache depend on which tests ran before it on the same
worker (issue 28 item 1). Each test has a folder of its own; only the tests marked
``shared_cache`` (the ones that compile, and ask for their engine) share
one per run, so a system one of them compiled is loaded by the others. ``slow`` says only
that a test is left out of the default set (``-m "not slow"``); CI runs it all the same.
It is marked where the test or its case is defined (``pytest_generate_tests`` below keeps
a case of every parametrized test in the default set). tests/README.md lists the files by
feature."""

from __future__ import annotations

import os
import shutil

import pytest


def _is_slow(value) -> bool:
    """Whether a parameter value is a ``pytest.param(..., marks=pytest.mark.slow)``."""
    return any(getattr(mark, "name", None) == "slow" for mark in getattr(value, "marks", ()))


def pytest_generate_tests(metafunc):
    """A parametrized test keeps at least one case in the default set (``-m "not
    slow"``): a test whose every case is slow is marked slow where it is defined, so
    that its absence from the quick set is read at the test, not worked out from its
    cases. Checked whenever the test's file is collected, whatever ``-m`` or ``-k``."""
    if metafunc.definition.get_closest_marker("slow") is not None:
        return
    for marker in metafunc.definition.iter_markers("parametrize"):
        values = marker.args[1] if len(marker.args) > 1 else marker.kwargs.get("argvalues", ())
        if not isinstance(values, (list, tuple)):
            continue  # an iterator, which pytest's own parametrize is still to read
        if values and all(_is_slow(v) for v in values):
            pytest.fail(
                f"{metafunc.definition.nodeid}: every case of {marker.args[0]!r} is marked "
                "slow; mark the test slow as a whole (@pytest.mark.slow) instead",
                pytrace=False,
            )


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
