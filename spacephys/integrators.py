"""Integrator specs and the INTEGRATORS registry: a method is a coefficient table plus its facts.

Every fixed-step method here runs through one of two kernels (kernels/integrate.py):
drift/kick splittings and explicit Runge-Kutta tableaux. Adding a method is adding a table.
"""
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Integrator:
    """What a method is and what it promises.

    name : registry key; order : global order of accuracy; symplectic : preserves phase-space
    volume (bounded energy error, no drift); adaptive : chooses its own substeps;
    family : "splitting" (drift, kick tables) or "rk" (a, b tableau);
    evaluations : force evaluations per step; reference : where the coefficients come from.
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
    _composed_leapfrog("yoshida4", 4, [1.0 / (2.0 - 2.0 ** (1.0 / 3.0))],
                       _YOSHIDA + ", eq. (4.14)"),
    _composed_leapfrog("yoshida6", 6,
                       [-0.117767998417887e1, 0.235573213359357e0, 0.784513610477560e0],
                       _YOSHIDA + ", Table 1, solution A"),
    _composed_leapfrog("yoshida8", 8,
                       [0.102799849391985e0, -0.196061023297549e1, 0.193813913762276e1,
                        -0.158240635368243e0, -0.144485223686048e1, 0.253693336566229e0,
                        0.914844246229740e0],
                       _YOSHIDA + ", Table 2, solution D"),
]

INTEGRATORS = {spec.name: spec for spec in _ALL}


def get_integrator(name):
    """The spec registered under name; ValueError listing the valid names otherwise."""
    if isinstance(name, Integrator):
        return name
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise ValueError(f"integrator={name!r} is not known; valid: {', '.join(INTEGRATORS)}") from None
