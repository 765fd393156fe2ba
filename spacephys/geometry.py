"""Centres of mass of point-mass shapes (the polygon with masses at its vertices of
Laird & Jamin, *Basic Game Physics*)."""

from . import _validate as check


def polygon_center_of_mass(vertices, masses):
    """x_c = sum x_i m_i / sum m_i over a polygon's vertices.

    vertices : (n, 2) or (n, 3) [length]; masses : (n,) >= 0 [mass], not all zero.
    Returns (2,) or (3,) [length].
    """
    vertices = check.floats("vertices", vertices, (None, None))
    if vertices.shape[1] not in (2, 3) or vertices.shape[0] == 0:
        raise ValueError(f"vertices has shape {vertices.shape}, expected (n, 2) or (n, 3), n >= 1")
    masses = check.floats("masses", masses, (vertices.shape[0],), minimum=0.0)
    total = masses.sum()
    if total == 0:
        raise ValueError("masses: all zero, so there is no centre of mass")
    return (masses[:, None] * vertices).sum(axis=0) / total
