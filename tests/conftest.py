import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))   # tests/reference.py


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


def pytest_collection_modifyitems(config, items):
    """The files with the most tests first, each file's tests in their order: `dev.py test`
    hands whole files to a worker per core as each frees up, and a long file handed out last
    would leave the other cores idle while it compiles."""
    from collections import Counter
    count = Counter(item.path for item in items)
    items.sort(key=lambda item: -count[item.path])
