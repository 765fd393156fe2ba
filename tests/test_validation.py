"""`spacephys validate`: every integrator of the registry on every reference problem, against
REBOUND's IAS15 on the same initial conditions, at stated tolerances.

EXPECTED holds the (position error, energy error) measured when the table was set, and the
test derives the bounds from them. Below SATURATED (1e-2 of the system's size) a value must
stay within 10x of its measurement, with floors of 1e-14 and 5e-15: many entries are round-off
accumulated over up to 5e5 steps, which moves by a few times with any change in the order of
operations; a method that loses an order, a wrong coefficient or a broken kernel misses by
orders of magnitude. At or above it the error is of the order of the system's size (Euler's
planet 240 sizes away), where an upper bound cannot fail: such a value must stay within a
factor of 2 of its measurement, both ways (it is deterministic, and a method changed in any
real way moves it far more). FAILS: the method refuses the problem with a clear error
(Wisdom-Holman needs a dominant mass). DIVERGES: the fixed step cannot resolve the
encounters; the table in docs/validation.md says so, and this checks that it still does
rather than quietly passing.
"""
import pytest

from spacephys.integrators import INTEGRATORS
from spacephys.study.validate import PROBLEMS, format_markdown, validate

FAILS, DIVERGES = "fails", "diverges"
SATURATED = 1e-2

EXPECTED = {
    'kepler_e0': {
        'euler': (2.34e+00, 5.77e-01),
        'symplectic_euler': (4.39e-02, 1.99e-07),
        'leapfrog': (2.07e-02, 3.96e-13),
        'rk4': (3.92e-06, 5.34e-08),
        'yoshida4': (4.95e-05, 7.11e-15),
        'yoshida6': (4.58e-09, 1.25e-14),
        'yoshida8': (2.50e-11, 1.23e-14),
        'gauss_radau': (4.28e-14, 8.88e-16),
        'wisdom_holman': (3.31e-12, 6.12e-14),
        'wisdom_holman_corrected': (3.33e-12, 6.14e-14),
    },
    'kepler_e0.5': {
        'euler': (1.15e+01, 6.77e-01),
        'symplectic_euler': (3.44e-01, 9.00e-03),
        'leapfrog': (3.84e-02, 5.44e-08),
        'rk4': (2.48e-05, 9.50e-08),
        'yoshida4': (8.37e-05, 8.66e-15),
        'yoshida6': (5.57e-09, 5.37e-14),
        'yoshida8': (5.13e-11, 2.52e-14),
        'gauss_radau': (3.90e-14, 1.33e-15),
        'wisdom_holman': (9.92e-12, 4.46e-14),
        'wisdom_holman_corrected': (8.72e-12, 4.46e-14),
    },
    'kepler_e0.9': {
        'euler': (2.43e+02, 1.69e+00),
        'symplectic_euler': (1.04e+01, 6.65e-03),
        'leapfrog': (5.28e-01, 3.14e-04),
        'rk4': (3.96e-03, 1.14e-06),
        'yoshida4': (4.62e-03, 4.10e-11),
        'yoshida6': (6.79e-07, 1.42e-13),
        'yoshida8': (5.61e-09, 1.98e-13),
        'gauss_radau': (7.29e-12, 3.44e-15),
        'wisdom_holman': (1.93e-11, 9.70e-14),
        'wisdom_holman_corrected': (1.93e-11, 9.02e-14),
    },
    'kepler_e0.99': {
        'euler': (2.48e+04, 2.03e+01),
        'symplectic_euler': (1.60e+02, 7.87e-01),
        'leapfrog': (2.72e+01, 7.97e-04),
        'rk4': (5.52e+01, 4.46e-03),
        'yoshida4': (3.01e+01, 9.42e-04),
        'yoshida6': (2.35e-01, 4.91e-08),
        'yoshida8': (1.35e-02, 2.43e-11),
        'gauss_radau': (5.85e-09, 2.78e-14),
        'wisdom_holman': (6.82e-08, 1.11e-12),
        'wisdom_holman_corrected': (6.82e-08, 1.08e-12),
    },
    'hyperbolic': {
        'euler': (4.09e-03, 6.41e-03),
        'symplectic_euler': (3.50e-06, 6.14e-06),
        'leapfrog': (9.04e-07, 5.77e-15),
        'rk4': (2.48e-12, 5.46e-14),
        'yoshida4': (3.17e-12, 4.44e-15),
        'yoshida6': (9.96e-14, 1.33e-15),
        'yoshida8': (1.17e-13, 3.12e-14),
        'gauss_radau': (1.29e-15, 4.44e-16),
        'wisdom_holman': (1.89e-14, 4.44e-16),
        'wisdom_holman_corrected': (1.42e-14, 1.34e-14),
    },
    'outer_solar_system': {
        'euler': (2.31e+00, 8.10e-01),
        'symplectic_euler': (3.80e-01, 4.67e-04),
        'leapfrog': (8.55e-02, 4.48e-05),
        'rk4': (5.96e-04, 5.59e-06),
        'yoshida4': (6.48e-04, 3.89e-07),
        'yoshida6': (1.66e-07, 9.92e-11),
        'yoshida8': (2.30e-09, 1.70e-12),
        'gauss_radau': (1.20e-13, 6.66e-16),
        'wisdom_holman': (9.49e-07, 1.65e-08),
        'wisdom_holman_corrected': (6.38e-09, 3.44e-11),
    },
    'pythagorean': {
        'euler': DIVERGES,  # energy error 3.7e+01
        'symplectic_euler': DIVERGES,  # energy error 3.7e+02
        'leapfrog': DIVERGES,  # energy error 3.7e+02
        'rk4': DIVERGES,  # energy error 6.1e+03
        'yoshida4': DIVERGES,  # energy error 3.8e+03
        'yoshida6': DIVERGES,  # energy error 1.9e+03
        'yoshida8': DIVERGES,  # energy error 5.2e+02
        'gauss_radau': (1.25e-03, 1.07e-11),
        'wisdom_holman': DIVERGES,  # energy error 9.3e+02
        'wisdom_holman_corrected': DIVERGES,  # energy error 9.3e+02
    },
    'figure_eight': {
        'euler': (3.06e+00, 4.80e-01),
        'symplectic_euler': (3.15e-03, 8.24e-06),
        'leapfrog': (1.92e-03, 1.88e-10),
        'rk4': (1.88e-07, 2.66e-09),
        'yoshida4': (2.93e-07, 6.66e-15),
        'yoshida6': (5.04e-12, 6.66e-15),
        'yoshida8': (2.68e-12, 5.20e-14),
        'gauss_radau': (4.85e-14, 5.55e-16),
        'wisdom_holman': FAILS,
        'wisdom_holman_corrected': FAILS,
    },
    'close_encounter': {
        'euler': (1.72e+00, 7.31e-02),
        'symplectic_euler': (8.09e-03, 4.00e-05),
        'leapfrog': (7.25e-03, 1.38e-10),
        'rk4': (2.85e-04, 1.21e-05),
        'yoshida4': (2.71e-04, 1.20e-11),
        'yoshida6': (2.70e-06, 7.10e-13),
        'yoshida8': (5.01e-07, 4.42e-12),
        'gauss_radau': (7.94e-14, 2.22e-15),
        'wisdom_holman': (7.25e-03, 1.23e-09),
        'wisdom_holman_corrected': (7.25e-03, 5.19e-10),
    },
}


@pytest.fixture(scope="module")
def results():
    return validate()


def test_every_problem_and_integrator_is_covered():
    assert set(EXPECTED) == set(PROBLEMS)
    for problem in EXPECTED.values():
        assert list(problem) == list(INTEGRATORS)


@pytest.mark.parametrize("problem,integrator",
                         [(p, i) for p in EXPECTED for i in EXPECTED[p]])
def test_against_rebound_ias15(results, problem, integrator):
    row = {r["integrator"]: r for r in results[problem]["rows"]}[integrator]
    expected = EXPECTED[problem][integrator]
    if expected == FAILS:
        assert row["status"].startswith("failed"), row
        return
    assert row["status"] == "ok", row
    if expected == DIVERGES:
        assert row["energy_error"] > 10, row
        return
    for name, measured, floor in zip(("position_error", "energy_error"), expected,
                                     (1e-14, 5e-15)):
        value = row[name]
        if measured >= SATURATED:
            assert measured / 2 <= value <= 2 * measured, (name, row)
        else:
            assert value <= max(10 * measured, floor), (name, row)


def test_rebound_reference_is_accurate(results):
    # the oracle itself: IAS15 at its default tolerance keeps energy to 1e-10 or better
    for name, res in results.items():
        assert res["rebound_ias15"]["energy_error"] < 1e-10, name


def test_markdown_table_lists_every_pair(results):
    table = format_markdown(results)
    assert table.count("\n| | ") == len(PROBLEMS) * len(INTEGRATORS)
    assert "| | wisdom_holman | | failed: a Kepler drift did not converge | | |" in table
