"""Accelerations [length/time^2] of every body under one gravity model; arrays in, `out` written.

Models (the integer `model` argument):
  NONE     no gravity;
  DIRECT   direct summation F = G m1 m2 / D^2: the bodies listed in `src` (active, massive) pull
           every body; the bodies in `passive` (test particles, ships, debris) feel but never pull;
  UNIFORM  a constant field `field` (the seed's `y += gravity` near a planet's surface);
  CENTRAL  a fixed body of mass `field_mass` at `field` pulls every body; bodies ignore each other.
Softening is Plummer's: a = G m d / (|d|^2 + eps2)^(3/2). Two bodies at exactly the same point
(|d|^2 + eps2 == 0) exert no force on each other: the direction is undefined, and a zero keeps
the state finite instead of NaN.
"""
import numba
import numpy as np

from .._jit import PARALLEL_MIN_PAIRS, kernel

NONE, DIRECT, UNIFORM, CENTRAL = 0, 1, 2, 3
ALL, PULLING, PASSIVE = 0, 1, 2          # which bodies' accelerations to compute


@kernel(fast=True)
def _pull(x, y, z, s, eps2):
    """Acceleration / G at (x, y, z) from point masses s[3] at (s[0], s[1], s[2]), s a (4, ns)
    array: three floats."""
    ax = 0.0
    ay = 0.0
    az = 0.0
    for j in range(s.shape[1]):
        dx = s[0, j] - x
        dy = s[1, j] - y
        dz = s[2, j] - z
        r2 = dx * dx + dy * dy + dz * dz + eps2
        d3 = r2 * np.sqrt(r2)
        # a select, not a branch, so the loop still vectorises; d3 == 0 is the coincident case
        w = s[3, j] / d3 if d3 > 0.0 else 0.0
        ax += w * dx
        ay += w * dy
        az += w * dz
    return ax, ay, az


@kernel(fast=True, parallel=True, inline=True)
def _pull_all(targets, pos, s, G, eps2, out):
    """out[k] = G * pull of the sources on pos[k] for every k in targets; threads when it pays.

    Each target's sum runs in a fixed order on one thread, so the result does not depend on
    the thread count.
    """
    if targets.size * s.shape[1] >= PARALLEL_MIN_PAIRS:
        for a in numba.prange(targets.size):
            k = targets[a]
            ax, ay, az = _pull(pos[k, 0], pos[k, 1], pos[k, 2], s, eps2)
            out[k, 0] = G * ax
            out[k, 1] = G * ay
            out[k, 2] = G * az
    else:
        for a in range(targets.size):
            k = targets[a]
            ax, ay, az = _pull(pos[k, 0], pos[k, 1], pos[k, 2], s, eps2)
            out[k, 0] = G * ax
            out[k, 1] = G * ay
            out[k, 2] = G * az


@kernel(inline=True)
def gather_sources(src, pos, mass, scratch):
    """The pulling bodies' x, y, z, m into scratch's rows (4, ns): separate contiguous rows,
    so that the force loops load them unit-stride."""
    for a in range(src.size):
        k = src[a]
        scratch[0, a] = pos[k, 0]
        scratch[1, a] = pos[k, 1]
        scratch[2, a] = pos[k, 2]
        scratch[3, a] = mass[k]


@kernel(parallel=True, inline=True)
def accelerations(pos, model, mass, src, passive, G, eps2, field, field_mass, still, scratch,
                  out, which=ALL):
    """Write the gravitational acceleration of every body into out.

    pos : (n, 3) float64 [length]
    model : int, NONE | DIRECT | UNIFORM | CENTRAL; mass : (n,) float64 [mass]
    src : (ns,) int64, indices of the bodies that pull (DIRECT); passive : (np,) int64, the rest
    G : float [length^3 / (mass time^2)]; eps2 : float, Plummer softening squared [length^2]
    field : (3,) float64, the uniform acceleration (UNIFORM) or the fixed body's position (CENTRAL)
    field_mass : float, the fixed body's mass (CENTRAL)
    still : (k,) int64, immovable bodies: their acceleration is zero, so they stay put
    scratch : (4, ns) float64 for DIRECT, (4, 1) for CENTRAL: the sources' x, y, z, m
              (exactly that wide, so its rows are contiguous and the inner loop vectorises)
    out : (n, 3) float64 [length / time^2]
    which : ALL, or with DIRECT only the rows of the PULLING or of the PASSIVE bodies
    """
    n = pos.shape[0]
    if model == DIRECT or model == CENTRAL:
        if model == DIRECT:
            gather_sources(src, pos, mass, scratch)
        else:
            scratch[0, 0] = field[0]
            scratch[1, 0] = field[1]
            scratch[2, 0] = field[2]
            scratch[3, 0] = field_mass
        if which != PASSIVE or model != DIRECT:
            _pull_all(src, pos, scratch, G, eps2, out)
        if which != PULLING or model != DIRECT:
            _pull_all(passive, pos, scratch, G, eps2, out)
    elif model == UNIFORM:
        for i in range(n):
            out[i, 0] = field[0]
            out[i, 1] = field[1]
            out[i, 2] = field[2]
    else:
        for i in range(n):
            out[i, 0] = 0.0
            out[i, 1] = 0.0
            out[i, 2] = 0.0
    for a in range(still.size):
        k = still[a]
        out[k, 0] = 0.0
        out[k, 1] = 0.0
        out[k, 2] = 0.0
