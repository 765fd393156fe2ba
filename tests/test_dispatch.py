"""Calling kernels past numba's per-call typing (spacephys/_dispatch.py)."""
import numpy as np
from numba import njit

from spacephys._dispatch import _key, fast_call


@njit(cache=False)
def _total(a, scale):
    s = 0.0
    for x in a.ravel():
        s += x
    return s * scale


def test_key_tells_apart_what_numba_types_apart():
    a = np.zeros((4, 3))
    ro = a.copy()
    ro.flags.writeable = False
    keys = {_key(a), _key(a[:, :2]), _key(ro), _key(a.astype(np.float32)), _key(a[0]),
            _key(np.asfortranarray(a))}
    assert len(keys) == 6                       # layout, writeability, dtype, ndim
    assert _key(a) == _key(np.ones((7, 3)))     # same numba type, same key
    assert _key(1) != _key(1.0) and _key(True) != _key(1)
    assert _key((a, 1.0)) == _key((np.ones((2, 3)), 2.0))
    assert _key(object()) is None and _key((a, object())) is None


def test_fast_call_gives_the_dispatcher_result_for_every_type():
    call = fast_call(_total)
    a = np.arange(12.0).reshape(4, 3)
    assert call(a, 2.0) == 132.0 and call(a, 2.0) == 132.0      # typed, then cached
    # another type after the first: the key differs, so the dispatcher types it afresh
    assert call(a.astype(np.float32), 1.0) == 66.0
    assert call(a[:, :2], 1.0) == _total(a[:, :2], 1.0) == 40.0
    assert call(np.asfortranarray(a), 1) == 66.0
    assert len(_total.signatures) == 4
