"""Test-wide setup: compiled systems are cached in this run's temporary folder, never in
the user's ~/.cache, so a clean machine (CI) and a developer's one behave the same."""

from __future__ import annotations

import os
import shutil

import pytest


@pytest.fixture(scope="session", autouse=True)
def lamech_cache_dir(tmp_path_factory):
    """``LAMECH_CACHE_DIR`` for the test process and the processes it starts: one folder
    per run, shared by pytest-xdist's workers (the parent of a worker's base folder),
    so a system compiled in one test is loaded from the cache in the others."""
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent
    path = base / "lamech-cache"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LAMECH_CACHE_DIR", str(path))
        yield path


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
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run"],
        )
        try:
            yield browser
        finally:
            browser.close()
