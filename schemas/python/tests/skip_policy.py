"""Under CI a skipped test is a failed test.

With the ``CI`` environment variable set and non-empty (``.ci/run`` runs with
``CI=true``), every skip - ``pytest.skip``, ``pytest.importorskip``, a skip mark - is
reported as a failure that keeps the skip's reason: ``scripts/test`` installs all the
tests need, so a skip there means a broken install, not a test that may be left out.
Without ``CI`` a skip stays a skip (``pytest -rs`` lists why).

Loaded by ``conftest.py`` here and by ``tests/python/conftest.py``.
"""

import os

import pytest


def under_ci():
    """Whether skips are failures: ``CI`` is set and non-empty."""
    return bool(os.environ.get("CI"))


def _skip_to_failure(report):
    if not (under_ci() and report.skipped) or hasattr(report, "wasxfail"):
        return
    longrepr = report.longrepr
    reason = longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
    report.outcome = "failed"
    report.longrepr = f"would skip, and CI is set, so it fails: {reason}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """A test (or its fixture) that skipped."""
    outcome = yield
    _skip_to_failure(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    """A whole module that skipped while importing (``importorskip`` at the top)."""
    outcome = yield
    _skip_to_failure(outcome.get_result())
