"""kernels/conics.py: a ring's states compiled are orbits.elements_to_state's, bit for bit."""
import math

import numpy as np
import pytest

from spacephys import orbits
from spacephys.kernels import conics


def test_compiled_states_are_the_python_functions_bits():
    # M far outside [-pi, pi] (reduced by %), e from 0 to nearly 1 (the series of
    # mean_anomaly near E = 0), planar and polar orbits
    rng = np.random.default_rng(11)
    k = 3000
    mu, a = rng.uniform(1e-3, 1e3, k), rng.uniform(1e-2, 1e4, k)
    e = np.concatenate([np.zeros(100), rng.uniform(0.0, 0.999999, k - 200), np.full(100, 0.999)])
    inc = np.concatenate([np.zeros(k // 2), rng.uniform(0.0, math.pi, k - k // 2)])
    node, peri = rng.uniform(0.0, 2 * math.pi, k), rng.uniform(-10.0, 10.0, k)
    M = np.concatenate([rng.uniform(-1e4, 1e4, k // 3), rng.uniform(-0.4, 0.4, k // 3),
                        rng.uniform(0.0, 2 * math.pi, k - 2 * (k // 3))])
    M[:6] = [0.0, -0.0, math.pi, -math.pi, 2 * math.pi, 1e300]
    pos, vel = np.empty((k, 3)), np.empty((k, 3))
    conics.elliptic_states(mu, a, e, inc, node, peri, M, pos, vel)
    for j in range(k):
        p, v = orbits.elements_to_state(mu[j], a[j], e[j], inc[j], node[j], peri[j], M=M[j])
        assert p.tobytes() == pos[j].tobytes() and v.tobytes() == vel[j].tobytes(), j


def test_the_python_twins_are_the_kernels():
    for M, e in [(0.3, 0.1), (-7.0, 0.9), (1e300, 0.5), (0.0, 0.0), (-0.0, 0.999)]:
        assert conics.solve_kepler(M, e).hex() == conics.py.solve_kepler(M, e).hex()
        assert conics.elliptic_anomaly(M, e).hex() == conics.py.elliptic_anomaly(M, e).hex()
    for x in (0.0, -0.0, 2.0, -3.0):
        assert conics.sign(x).hex() == conics.py.sign(x).hex() == float(np.sign(x)).hex()
    assert math.isnan(conics.sign(math.nan)) and math.isnan(conics.py.sign(math.nan))


def test_keplers_equation_refuses_what_it_cannot_solve():
    for M, e, field in [(0.3, 1.0, "e = 1.0"), (0.3, -0.1, "e = -0.1"), (math.nan, 0.5, "M")]:
        with pytest.raises(ValueError, match=field):
            orbits.solve_kepler(M, e)
