"""`spacephys validate`: every integrator of the registry on every reference problem, against
REBOUND's IAS15 on the same initial conditions, at stated tolerances.

Each bound is 10x the value measured when it was set (comment: measured position error,
energy error), with floors of 1e-14 and 5e-15: many entries are round-off accumulated over up
to 5e5 steps, which moves by a few times with any change in the order of operations. A
method that loses an order, a wrong coefficient or a broken kernel misses by orders of
magnitude. FAILS: the method refuses the problem with a clear error (Wisdom-Holman needs a
dominant mass). DIVERGES: the fixed step cannot resolve the encounters; the table in
docs/validation.md says so, and this checks that it still does rather than quietly passing.
"""
import pytest

from spacephys.integrators import INTEGRATORS
from spacephys.study.validate import PROBLEMS, format_markdown, validate

FAILS, DIVERGES = "fails", "diverges"

EXPECTED = {
    'kepler_e0': {
        'euler': (2.4e+01, 5.8e+00),  # 2.3e+00, 5.8e-01
        'symplectic_euler': (4.4e-01, 2.0e-06),  # 4.4e-02, 2.0e-07
        'leapfrog': (2.1e-01, 4.0e-12),  # 2.1e-02, 4.0e-13
        'rk4': (4.0e-05, 5.4e-07),  # 3.9e-06, 5.3e-08
        'yoshida4': (5.0e-04, 7.2e-14),  # 4.9e-05, 7.1e-15
        'yoshida6': (4.6e-08, 1.3e-13),  # 4.6e-09, 1.3e-14
        'yoshida8': (2.6e-10, 1.3e-13),  # 2.5e-11, 1.2e-14
        'gauss_radau': (9.4e-13, 8.9e-15),  # 9.3e-14, 8.9e-16
        'wisdom_holman': (3.4e-11, 6.2e-13),  # 3.4e-12, 6.1e-14
        'wisdom_holman_corrected': (3.4e-11, 6.2e-13),  # 3.4e-12, 6.2e-14
    },
    'kepler_e0.5': {
        'euler': (1.2e+02, 6.8e+00),  # 1.2e+01, 6.8e-01
        'symplectic_euler': (3.5e+00, 9.0e-02),  # 3.4e-01, 9.0e-03
        'leapfrog': (3.9e-01, 5.5e-07),  # 3.8e-02, 5.4e-08
        'rk4': (2.5e-04, 9.6e-07),  # 2.5e-05, 9.5e-08
        'yoshida4': (8.4e-04, 8.7e-14),  # 8.4e-05, 8.7e-15
        'yoshida6': (5.6e-08, 5.4e-13),  # 5.6e-09, 5.4e-14
        'yoshida8': (5.2e-10, 2.6e-13),  # 5.2e-11, 2.5e-14
        'gauss_radau': (3.1e-12, 8.9e-15),  # 3.1e-13, 8.9e-16
        'wisdom_holman': (9.6e-11, 4.5e-13),  # 9.6e-12, 4.5e-14
        'wisdom_holman_corrected': (9.6e-11, 4.5e-13),  # 9.6e-12, 4.5e-14
    },
    'kepler_e0.9': {
        'euler': (2.5e+03, 1.7e+01),  # 2.4e+02, 1.7e+00
        'symplectic_euler': (1.1e+02, 6.7e-02),  # 1.0e+01, 6.7e-03
        'leapfrog': (5.3e+00, 3.2e-03),  # 5.3e-01, 3.1e-04
        'rk4': (4.0e-02, 1.2e-05),  # 4.0e-03, 1.1e-06
        'yoshida4': (4.7e-02, 4.2e-10),  # 4.6e-03, 4.1e-11
        'yoshida6': (6.8e-06, 1.5e-12),  # 6.8e-07, 1.4e-13
        'yoshida8': (5.7e-08, 2.0e-12),  # 5.6e-09, 2.0e-13
        'gauss_radau': (1.9e-11, 3.5e-14),  # 1.9e-12, 3.4e-15
        'wisdom_holman': (2.5e-10, 9.8e-13),  # 2.5e-11, 9.7e-14
        'wisdom_holman_corrected': (8.4e-10, 4.6e-13),  # 8.4e-11, 4.5e-14
    },
    'kepler_e0.99': {
        'euler': (2.5e+05, 2.1e+02),  # 2.5e+04, 2.0e+01
        'symplectic_euler': (1.6e+03, 7.9e+00),  # 1.6e+02, 7.9e-01
        'leapfrog': (2.8e+02, 8.0e-03),  # 2.7e+01, 8.0e-04
        'rk4': (5.6e+02, 4.5e-02),  # 5.5e+01, 4.5e-03
        'yoshida4': (3.1e+02, 9.5e-03),  # 3.0e+01, 9.4e-04
        'yoshida6': (2.4e+00, 5.0e-07),  # 2.4e-01, 4.9e-08
        'yoshida8': (1.4e-01, 2.5e-10),  # 1.4e-02, 2.4e-11
        'gauss_radau': (8.0e-09, 2.8e-13),  # 7.9e-10, 2.8e-14
        'wisdom_holman': (7.5e-07, 1.2e-11),  # 7.5e-08, 1.1e-12
        'wisdom_holman_corrected': (7.5e-07, 1.3e-11),  # 7.5e-08, 1.3e-12
    },
    'hyperbolic': {
        'euler': (4.1e-02, 6.5e-02),  # 4.1e-03, 6.4e-03
        'symplectic_euler': (3.5e-05, 6.2e-05),  # 3.5e-06, 6.1e-06
        'leapfrog': (9.1e-06, 5.8e-14),  # 9.0e-07, 5.8e-15
        'rk4': (2.5e-11, 5.5e-13),  # 2.5e-12, 5.5e-14
        'yoshida4': (3.2e-11, 4.5e-14),  # 3.2e-12, 4.4e-15
        'yoshida6': (1.1e-12, 1.4e-14),  # 1.0e-13, 1.3e-15
        'yoshida8': (1.2e-12, 3.2e-13),  # 1.2e-13, 3.1e-14
        'gauss_radau': (1.0e-14, 5.0e-15),  # 5.2e-16, 4.4e-16
        'wisdom_holman': (1.9e-13, 5.0e-15),  # 1.8e-14, 4.4e-16
        'wisdom_holman_corrected': (1.6e-13, 1.3e-13),  # 1.5e-14, 1.2e-14
    },
    'outer_solar_system': {
        'euler': (2.4e+01, 8.2e+00),  # 2.3e+00, 8.1e-01
        'symplectic_euler': (3.9e+00, 4.7e-03),  # 3.8e-01, 4.7e-04
        'leapfrog': (8.6e-01, 4.5e-04),  # 8.5e-02, 4.5e-05
        'rk4': (6.0e-03, 5.6e-05),  # 6.0e-04, 5.6e-06
        'yoshida4': (6.5e-03, 3.9e-06),  # 6.5e-04, 3.9e-07
        'yoshida6': (1.7e-06, 1.0e-09),  # 1.7e-07, 9.9e-11
        'yoshida8': (2.3e-08, 1.7e-11),  # 2.3e-09, 1.7e-12
        'gauss_radau': (3.4e-12, 6.7e-15),  # 3.4e-13, 6.7e-16
        'wisdom_holman': (9.5e-06, 1.7e-07),  # 9.5e-07, 1.7e-08
        'wisdom_holman_corrected': (6.4e-08, 3.5e-10),  # 6.4e-09, 3.4e-11
    },
    'pythagorean': {
        'euler': DIVERGES,  # energy error 3.7e+01
        'symplectic_euler': DIVERGES,  # energy error 3.7e+02
        'leapfrog': DIVERGES,  # energy error 3.7e+02
        'rk4': DIVERGES,  # energy error 6.1e+03
        'yoshida4': DIVERGES,  # energy error 3.8e+03
        'yoshida6': DIVERGES,  # energy error 1.9e+03
        'yoshida8': DIVERGES,  # energy error 5.2e+02
        'gauss_radau': (2.2e-03, 1.1e-10),  # 2.2e-04, 1.1e-11
        'wisdom_holman': DIVERGES,  # energy error 9.3e+02
        'wisdom_holman_corrected': DIVERGES,  # energy error 9.3e+02
    },
    'figure_eight': {
        'euler': (3.1e+01, 4.9e+00),  # 3.1e+00, 4.8e-01
        'symplectic_euler': (3.2e-02, 8.3e-05),  # 3.1e-03, 8.2e-06
        'leapfrog': (2.0e-02, 1.9e-09),  # 1.9e-03, 1.9e-10
        'rk4': (1.9e-06, 2.7e-08),  # 1.9e-07, 2.7e-09
        'yoshida4': (3.0e-06, 6.7e-14),  # 2.9e-07, 6.7e-15
        'yoshida6': (5.1e-11, 6.7e-14),  # 5.0e-12, 6.7e-15
        'yoshida8': (2.7e-11, 5.2e-13),  # 2.7e-12, 5.2e-14
        'gauss_radau': (5.8e-13, 5.6e-15),  # 5.7e-14, 5.6e-16
        'wisdom_holman': FAILS,
        'wisdom_holman_corrected': FAILS,
    },
    'close_encounter': {
        'euler': (1.8e+01, 7.4e-01),  # 1.7e+00, 7.3e-02
        'symplectic_euler': (8.1e-02, 4.0e-04),  # 8.1e-03, 4.0e-05
        'leapfrog': (7.3e-02, 1.4e-09),  # 7.2e-03, 1.4e-10
        'rk4': (2.9e-03, 1.3e-04),  # 2.9e-04, 1.2e-05
        'yoshida4': (2.8e-03, 1.3e-10),  # 2.7e-04, 1.2e-11
        'yoshida6': (2.7e-05, 7.1e-12),  # 2.7e-06, 7.1e-13
        'yoshida8': (5.1e-06, 4.5e-11),  # 5.0e-07, 4.4e-12
        'gauss_radau': (7.3e-13, 2.3e-14),  # 7.3e-14, 2.2e-15
        'wisdom_holman': (7.3e-02, 1.3e-08),  # 7.3e-03, 1.2e-09
        'wisdom_holman_corrected': (7.3e-02, 5.2e-09),  # 7.3e-03, 5.2e-10
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
    position_bound, energy_bound = expected
    assert row["position_error"] <= position_bound, row
    assert row["energy_error"] <= energy_bound, row


def test_rebound_reference_is_accurate(results):
    # the oracle itself: IAS15 at its default tolerance keeps energy to 1e-10 or better
    for name, res in results.items():
        assert res["rebound_ias15"]["energy_error"] < 1e-10, name


def test_markdown_table_lists_every_pair(results):
    table = format_markdown(results)
    assert table.count("\n| | ") == len(PROBLEMS) * len(INTEGRATORS)
    assert "| | wisdom_holman | | failed: a Kepler drift did not converge | | |" in table
