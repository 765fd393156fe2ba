"""Integrator specs and the INTEGRATORS registry: a method is a coefficient table plus its facts.

Every fixed-step method here runs through one of two kernels (kernels/integrate.py):
drift/kick splittings and explicit Runge-Kutta tableaux. Adding a method is adding a table.
"""
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np


@dataclass(frozen=True)
class Integrator:
    """What a method is and what it promises.

    name : registry key; order : global order of accuracy; symplectic : preserves phase-space
    volume (bounded energy error, no drift); adaptive : chooses its own substeps;
    family : "splitting" (drift, kick tables), "rk" (a, b tableau), "gauss_radau" (nodes and
    the g <-> b conversions) or "wisdom_holman" (Kepler drifts about the heaviest body);
    evaluations : force evaluations per step (per corrector sweep for Gauss-Radau);
    reference : where the method comes from; corrector : order of the symplectic corrector.
    """
    name: str
    order: int
    symplectic: bool
    adaptive: bool
    family: str
    evaluations: int
    reference: str
    drift: np.ndarray = field(default=None, repr=False)
    kick: np.ndarray = field(default=None, repr=False)
    a: np.ndarray = field(default=None, repr=False)
    b: np.ndarray = field(default=None, repr=False)
    nodes: np.ndarray = field(default=None, repr=False)
    c_gb: np.ndarray = field(default=None, repr=False)
    d_bg: np.ndarray = field(default=None, repr=False)
    corrector: int = 0


def _frozen(values):
    arr = np.ascontiguousarray(values, dtype=np.float64)
    arr.flags.writeable = False
    return arr


def _splitting(name, order, drift, kick, reference, symplectic=True):
    return Integrator(name, order, symplectic, False, "splitting", int(np.count_nonzero(kick)),
                      reference, drift=_frozen(drift), kick=_frozen(kick))


def _composed_leapfrog(name, order, weights, reference):
    """The symmetric product S2(w_k h) ... S2(w_1 h) S2(w_0 h) S2(w_1 h) ... S2(w_k h) of
    drift-kick-drift leapfrogs, adjacent half drifts merged.

    weights : (w_1, ..., w_k) in the published order, w_1 next to the centre;
              w_0 = 1 - 2 sum(w_i) closes the sum to one step.
    """
    w = list(weights)
    w0 = 1.0 - 2.0 * sum(w)
    seq = w[::-1] + [w0] + w          # outermost first; symmetric, so either end is the start
    drift = [seq[0] / 2] + [(seq[i] + seq[i + 1]) / 2 for i in range(len(seq) - 1)] + [seq[-1] / 2]
    kick = seq + [0.0]
    return _splitting(name, order, drift, kick, reference)


def _rk(name, order, a, b, reference):
    b = _frozen(b)
    return Integrator(name, order, False, False, "rk", b.size, reference,
                      a=_frozen(a), b=b)


# The seven Gauss-Radau spacings on (0, 1] (Everhart 1985): with tau = 0 they are the nodes of the
# 8-point Radau quadrature, i.e. the roots of (P7(x) + P8(x)) / (1 + x) at x = 2 tau - 1 (checked
# in the tests).
_RADAU_NODES = (0.0562625605369221464656521910, 0.1802406917368923649875799428,
                0.3526247171131696373739078209, 0.5471536263305553830014485577,
                0.7342101772154105315232106546, 0.8853209468390957680903597629,
                0.9775206135612875018911745004)


def _gauss_radau(name):
    """Tables relating the Newton form a0 + sum_j g_j tau prod_{m<j} (tau - h_m) of the step's
    acceleration polynomial to its power form a0 + sum_k b_k tau^k, expanded in exact rational
    arithmetic from the (binary) node values and rounded once."""
    h = [Fraction(x) for x in _RADAU_NODES]
    C = [[Fraction(0)] * 7 for _ in range(7)]      # C[j][k]: tau^(k+1) in the j-th Newton term
    poly = [Fraction(1)]                              # prod (tau - h_m), lowest power first
    for j in range(7):
        for k, coeff in enumerate(poly):
            C[j][k] = coeff                           # times tau: power k + 1 -> b index k
        poly = [Fraction(0)] + poly                   # multiply by (tau - h_j)
        for k in range(len(poly) - 1):
            poly[k] -= h[j] * poly[k + 1]
    D = [[Fraction(0)] * 7 for _ in range(7)]         # C^-1, lower triangular as C is
    for i in range(7):
        for j in range(i + 1):
            D[i][j] = ((i == j) - sum(C[i][m] * D[m][j] for m in range(j, i))) / C[i][i]
    return Integrator(name, 15, False, True, "gauss_radau", 7,
                      "Everhart (1985); Rein & Spiegel, MNRAS 446 (2015) 1424; step criterion of "
                      "Pham, Rein & Spiegel, OJAp (2024)",
                      nodes=_frozen(_RADAU_NODES), c_gb=_frozen([[float(x) for x in r] for r in C]),
                      d_bg=_frozen([[float(x) for x in r] for r in D]))


_YOSHIDA = "H. Yoshida, Construction of higher order symplectic integrators, Phys. Lett. A 150 (1990) 262"

_ALL = [
    # x += v dt; v += a(x_old) dt: the textbook update, first order, energy drifts
    _rk("euler", 1, [[0.0]], [1.0], "forward Euler"),
    # v += a(x) dt; x += v_new dt
    _splitting("symplectic_euler", 1, [0.0, 1.0], [1.0, 0.0],
               "semi-implicit (symplectic) Euler; Hairer, Lubich & Wanner, GNI (2006) I.1"),
    # drift-kick-drift; velocity Verlet is the same method with the step boundary moved by half
    _splitting("leapfrog", 2, [0.5, 0.5], [1.0, 0.0],
               "Stormer-Verlet; Hairer, Lubich & Wanner, Acta Numerica 12 (2003) 399"),
    _rk("rk4", 4,
        [[0.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
        [1 / 6, 1 / 3, 1 / 3, 1 / 6], "classical Runge-Kutta (Kutta 1901)"),
    _composed_leapfrog("yoshida4", 4, [1.0 / (2.0 - 1.2599210498948732)],   # 2^(1/3)
                       _YOSHIDA + ", eq. (4.14)"),
    _composed_leapfrog("yoshida6", 6,
                       [-0.117767998417887e1, 0.235573213359357e0, 0.784513610477560e0],
                       _YOSHIDA + ", Table 1, solution A"),
    _composed_leapfrog("yoshida8", 8,
                       [0.102799849391985e0, -0.196061023297549e1, 0.193813913762276e1,
                        -0.158240635368243e0, -0.144485223686048e1, 0.253693336566229e0,
                        0.914844246229740e0],
                       _YOSHIDA + ", Table 2, solution D"),
    _gauss_radau("gauss_radau"),
    # order 2 in dt, but the error is epsilon dt^2 with epsilon the planet/star mass ratio; with
    # the corrector epsilon dt^4 + epsilon^2 dt^2
    Integrator("wisdom_holman", 2, True, False, "wisdom_holman", 1,
               "Wisdom & Holman, AJ 102 (1991) 1528, in Jacobi coordinates"),
    Integrator("wisdom_holman_corrected", 2, True, False, "wisdom_holman", 1,
               "Wisdom & Holman (1991) with the third-order symplectic corrector of Wisdom, "
               "Holman & Touma, Fields Inst. Commun. 10 (1996) 217", corrector=3),
]

INTEGRATORS = {spec.name: spec for spec in _ALL}


def get_integrator(name):
    """The spec registered under name (or a spec of the registry itself); ValueError listing
    the valid names otherwise."""
    if isinstance(name, Integrator) and INTEGRATORS.get(name.name) is name:
        return name
    if isinstance(name, str) and name in INTEGRATORS:
        return INTEGRATORS[name]
    raise ValueError(f"integrator={name!r} is not known; valid: {', '.join(INTEGRATORS)}")
