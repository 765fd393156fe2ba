import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))   # tests/reference.py


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)



# files whose tests compare measured times (the benchmarks' and the work-precision study's
# figures, recommend's choices by them): `dev.py test` runs them alone, after the rest, so
# that another worker's compilation does not skew what they measure (a single such test
# elsewhere is marked @pytest.mark.timed where it stands)
TIMED = ("test_recommend.py", "test_tradeoff.py")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name.startswith("test_bench_") or item.path.name in TIMED:
            item.add_marker(pytest.mark.timed)
