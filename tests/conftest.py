"""Test-wide setup: compiled systems are cached in this run's temporary folder, never in
the user's ~/.cache, so a clean machine (CI) and a developer's one behave the same."""

from __future__ import annotations

import os

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
