"""Make ``wearnav_schemas``, ``monitor`` and ``send`` importable from a checkout,
whichever directory pytest is started from; under CI a skip is a failure
(``skip_policy``)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from skip_policy import pytest_make_collect_report, pytest_runtest_makereport  # noqa: E402,F401
