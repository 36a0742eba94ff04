"""Make ``wearnav_schemas``, ``monitor`` and ``send`` importable from a checkout,
whichever directory pytest is started from."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
