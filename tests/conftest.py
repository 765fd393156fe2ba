import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))   # tests/reference.py


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)



# files whose tests compare measured times (one code's time against another's, recommend's
# choices by them, a busy core's share): `dev.py test` runs them alone, after the rest, so that
# another worker's compilation does not skew what they compare (a single such test elsewhere is
# marked @pytest.mark.timed where it stands). A benchmark's test that only checks its report
# (test_bench_play, _queries, _overhead, _compile, _tree but for one test, test_tradeoff) runs
# with the rest.
TIMED = ("test_bench_heavy.py", "test_bench_models.py", "test_bench_predict.py",
         "test_bench_threads.py", "test_recommend.py")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name in TIMED:
            item.add_marker(pytest.mark.timed)
