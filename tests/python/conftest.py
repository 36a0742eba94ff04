"""Under CI a skip is a failure, as in the schema tests (``skip_policy`` there)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "schemas" / "python" / "tests"))

from skip_policy import pytest_make_collect_report, pytest_runtest_makereport  # noqa: E402,F401
