"""The input checks every public call shares (spacephys/_validate.py): a new float64 array,
never the caller's, and errors that name the field and the value, on the fast paths for
float arrays and floats as on the general one."""
import numpy as np
import pytest

from spacephys import _validate as check


@pytest.mark.parametrize("value", [np.arange(6.0).reshape(2, 3), [[0.0, 1.0, 2.0]] * 2,
                                   np.arange(6).reshape(2, 3)])
def test_floats_is_a_new_float64_array_of_the_values(value):
    out = check.floats("x", value, (None, 3))
    assert out.dtype == np.float64 and np.array_equal(out, np.asarray(value, float))
    assert not np.shares_memory(out, np.asarray(value))
    out[0, 0] = 99.0
    assert np.asarray(value)[0, 0] == 0


@pytest.mark.parametrize("value, message", [
    (np.array([[0.0, np.nan, 1.0]]), r"x\[0\]\[1\] = nan: must be finite"),
    (np.array([[0.0, 1.0]]), r"x has shape \(1, 2\), expected \(n, 3\)"),
    (np.array([[True, False, True]]), "expected real numbers"),
    ("abc", "not text"),
])
def test_floats_names_the_field_and_value(value, message):
    with pytest.raises(ValueError, match=message):
        check.floats("x", value, (None, 3))


def test_per_body_broadcasts_a_float_and_checks_it():
    assert np.array_equal(check.per_body("r", 2.5, 3, minimum=0.0), [2.5, 2.5, 2.5])
    for bad, message in ((-1.0, r"r = -1.0: must be >= 0.0"), (float("inf"), "must be finite"),
                         (np.float64(-2.0), "must be >= 0.0")):
        with pytest.raises(ValueError, match=message):
            check.per_body("r", bad, 3, minimum=0.0)
