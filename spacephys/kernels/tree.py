"""Barnes-Hut tree gravity: an octree (a quadtree for bodies in a plane) rebuilt at every force
evaluation, walked by groups of targets, monopole and quadrupole moments, Plummer softening.

Written from the published algorithms: Barnes & Hut (1986) for the tree and its opening
angle; the linear (Morton-ordered) tree of Warren & Salmon (1993); the group walk with shared
interaction lists of Barnes (1990); the quadrupole of the softened potential as its Taylor
expansion about the centre of mass (as GADGET-2, Springel 2005, does for the monopole).

Build (`build`), from the sources s (4, ns): x, y, z, m (tape.gather), every evaluation:
  1. Morton keys of the sources in their bounding cube: 63 bits shared by the axes along which
     the sources spread (21 each in 3D, 31 in a plane), on threads;
  2. a stable radix sort of the keys (arrays.radix_order) (equal keys keep their order: deterministic);
  3. the nodes in depth-first order: a node is a range of the sorted sources; it splits at the
     first level where its keys differ (no chains of one-child nodes, so fewer than 2 ns
     nodes), and is a leaf at LEAF sources or fewer. `next` skips a node's subtree;
  4. moments, leaves on threads then the others from their children: mass, centre of mass,
     the second moment Q = sum m d d^T about it, the bodies' bounding box.
A node is accepted for a group of targets when the group's bounding box is farther from the
node's centre of mass than l / theta (l: the largest side of the bounding box of the node's
sources; Barnes and Hut's criterion, measured from the nearest point of the group) and does
not overlap the node's box (no target among the sources it stands for, whatever theta);
otherwise it is opened, and a leaf's sources are summed directly, as the direct kernel does.

Heavy sources (`split`: more than HEAVY of the total mass, so at most 1 / HEAVY of them: a
planet among its ring, a galaxy's core) stay out of the tree and are summed directly for every
target: a tree's relative error on the pull of a dominant mass would be as large as a light
ring's whole self-gravity.

Walk (`walk`, for `accelerations` and `tree_potential`): the targets are cut into
groups of at most GROUP (the tree's own nodes when the targets are its sources, otherwise runs
in Morton order); each group walks the tree once and keeps two lists, accepted nodes and leaf
sources, in single precision relative to the group's centre (eight lanes, not four; rounding
about 1e-6 of the force, below the tree's own error); then every target of the group sums
both lists, and the heavy sources in double precision. Each target's sums run in a fixed
order, so the result does not depend on the thread count.

Accelerations with r = x - com, s^2 = |r|^2 + eps2 (the Taylor expansion of the softened
potential -G m / s about the centre of mass):
  a = -G M r / s^3 + G [3 Q r / s^5 - 15/2 (r.Q r) r / s^7 + 3/2 tr(Q) r / s^5]
  phi = -G M / s - G/2 [3 (r.Q r) / s^5 - tr(Q) / s^3]
"""
from collections import namedtuple

import numba
import numpy as np
from numba import types

from .._jit import kernel, stack_rows
from . import arrays, gravity, pairs
from .diagnostics import add
from .tape import gather

# the model's table (kernels/gravity.py): G, eps2 as Direct's; theta the opening angle;
# quadrupole 1 for quadrupole moments, 0 for monopoles only; sources (4, ns) scratch
Tree = namedtuple("Tree", ("G", "eps2", "theta", "quadrupole", "sources"))

LEAF = 16            # sources in a leaf, at most (unless they share one Morton cell)
GROUP = 256          # targets that share one walk (the walk at 2e4 bodies: 128 took 1.2x as long, 512 as long)
LANES = 64          # groups are dealt to this many lanes, round robin, for the threads
MIN_PARALLEL = 2048  # fewest targets whose walk runs on threads
HEAVY = 0.01        # sources of more than this fraction of the total mass are summed directly

# node float columns (nodes (K, NF))
# (what the walk tests comes first: one cache line, then the box's far corner and the moments)
CX, CY, CZ, ROPEN2, LOX, LOY, LOZ, HIX, HIY, HIZ, M, QXX, QXY, QXZ, QYY, QYZ, QZZ, TR15 = \
    range(18)           # ROPEN2: (l / theta)^2; TR15: 3/2 tr(Q)
NF = 18
# node int columns (links (K, 4)): the node after its subtree, its sources' range, leaf or not
NEXT, LO, HI, IS_LEAF = range(4)
# list columns: accepted nodes (cells (11, cap)) and leaf sources (parts (4, cap))
CELL_ROWS = 11
# what build returns (build and walk are called by address, typed from their declarations,
# so that a scene's first compile builds the tree and its walk side by side):
# (sx, order, links, nodes, (lo, side, axes, bits))
_TREE = types.Tuple((types.Array(types.float64, 2, "C"), types.Array(types.int64, 1, "C"),
                     types.Array(types.int64, 2, "C"), types.Array(types.float64, 2, "C"),
                     types.Tuple((types.Array(types.float64, 1, "C"), types.float64,
                                  types.Array(types.bool_, 1, "C"), types.int64))))


# ----------------------------------------------------------------------------- keys

@kernel(inline=True)
def _box(s):
    """(lo (3,), side, axes (3,) bool, bits per axis): the sources' bounding cube and the axes
    they spread along."""
    lo = np.empty(3)
    hi = np.empty(3)
    for c in range(3):
        lo[c] = np.inf
        hi[c] = -np.inf
    for j in range(s.shape[1]):
        for c in range(3):
            v = s[c, j]
            if v < lo[c]:
                lo[c] = v
            if v > hi[c]:
                hi[c] = v
    side = 0.0
    naxes = 0
    axes = np.empty(3, np.bool_)
    for c in range(3):
        axes[c] = False
        if s.shape[1] and hi[c] > lo[c]:
            axes[c] = True
            naxes += 1
            side = max(side, hi[c] - lo[c])
    bits = 63 // naxes if naxes else 0
    return lo, side, axes, bits


@kernel(inline=True)
def _key(x, y, z, lo, side, axes, bits):
    """The Morton key of a point: the interleaved bits of its cell along the spread axes
    (clamped into the cube)."""
    cells = (1 << bits) - 1
    q = np.empty(3, np.int64)
    p = (x, y, z)
    n = 0
    for c in range(3):
        if axes[c]:
            u = (p[c] - lo[c]) / side * cells
            u = min(max(u, 0.0), float(cells))
            q[n] = np.int64(u)
            n += 1
    key = np.int64(0)
    for b in range(bits - 1, -1, -1):
        for a in range(n):
            key = (key << 1) | ((q[a] >> b) & 1)
    return key


@kernel(parallel=True)
def _keys(x, y, z, rows, lo, side, axes, bits, threaded):
    """(k,) int64 Morton keys of the points (x[r], y[r], z[r]) for r in rows."""
    keys = np.empty(rows.size, np.int64)
    if bits == 0:
        for i in range(rows.size):
            keys[i] = 0
        return keys
    if threaded:
        for i in numba.prange(rows.size):
            r = rows[i]
            keys[i] = _key(x[r], y[r], z[r], lo, side, axes, bits)
    else:
        for i in range(rows.size):
            r = rows[i]
            keys[i] = _key(x[r], y[r], z[r], lo, side, axes, bits)
    return keys


# ----------------------------------------------------------------------------- build

@kernel(inline=True)
def _digit(key, shift, mask):
    return (key >> shift) & mask


@kernel(inline=True)
def _first_at_least(keys, lo, hi, value, shift, mask):
    """The first index in [lo, hi) whose digit at shift is >= value (keys sorted, sharing
    their digits above shift)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if _digit(keys[mid], shift, mask) < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@kernel
def _topology(keys, naxes, bits):
    """links (K, 4) int64 in depth-first order: NEXT, LO, HI, IS_LEAF (see the module)."""
    ns = keys.size
    cap = max(16, ns // 2 + 16)
    links = np.empty((cap, 4), np.int64)
    mask = (1 << naxes) - 1 if naxes else 0
    top = (bits - 1) * naxes
    stack = np.empty((64 * 8 + 8, 3), np.int64)       # depth <= 63 levels, <= 8 children each
    sp = 0
    stack[0, 0] = 0
    stack[0, 1] = ns
    stack[0, 2] = top
    sp = 1
    K = 0
    first = np.empty(9, np.int64)
    while sp:
        sp -= 1
        lo = stack[sp, 0]
        hi = stack[sp, 1]
        shift = stack[sp, 2]
        if K == links.shape[0]:
            grown = np.empty((2 * K, 4), np.int64)
            for i in range(K):
                for c in range(4):
                    grown[i, c] = links[i, c]
            links = grown
        node = K
        K += 1
        links[node, LO] = lo
        links[node, HI] = hi
        links[node, IS_LEAF] = 1
        if hi - lo <= LEAF or naxes == 0:
            continue
        # the first level at which the range's keys differ (sorted: first and last suffice)
        while shift >= 0 and _digit(keys[lo], shift, mask) == _digit(keys[hi - 1], shift, mask):
            shift -= naxes
        if shift < 0:
            continue                    # every key equal: one leaf
        links[node, IS_LEAF] = 0
        d0 = _digit(keys[lo], shift, mask)
        d1 = _digit(keys[hi - 1], shift, mask)
        nc = 0
        start = lo
        for d in range(d0, d1 + 1):
            end = _first_at_least(keys, start, hi, d + 1, shift, mask) if d < d1 else hi
            if end > start:
                first[nc] = start
                nc += 1
                first[nc] = end
            start = end
        # children pushed last first, so that the first is the next node (depth-first order)
        for c in range(nc - 1, -1, -1):
            stack[sp, 0] = first[c]
            stack[sp, 1] = first[c + 1]
            stack[sp, 2] = shift - naxes
            sp += 1
    # NEXT: a node's index plus its subtree's size, summed from the last node back
    size = np.ones(K, np.int64)
    parent = np.empty(K, np.int64)
    # a node's parent is the nearest earlier node whose range holds it; found with a stack
    path = np.empty(K + 1, np.int64)
    depth = 0
    for i in range(K):
        while depth and links[path[depth - 1], HI] <= links[i, LO]:
            depth -= 1
        parent[i] = path[depth - 1] if depth else -1
        path[depth] = i
        depth += 1
    for i in range(K - 1, 0, -1):
        size[parent[i]] += size[i]
    for i in range(K):
        links[i, NEXT] = i + size[i]
    return links[:K]


@kernel(inline=True)
def _leaf_moments(nodes, i, lo, hi, sx):
    """Node i's moments from its sources sx[:, lo:hi] (see _store)."""
    m = 0.0
    mx = 0.0
    my = 0.0
    mz = 0.0
    for j in range(lo, hi):
        w = sx[3, j]
        m += w
        mx += w * sx[0, j]
        my += w * sx[1, j]
        mz += w * sx[2, j]
    cx = mx / m if m > 0.0 else 0.0          # m = 0: no sources (all were heavy)
    cy = my / m if m > 0.0 else 0.0
    cz = mz / m if m > 0.0 else 0.0
    q = np.empty(6)
    blo = np.empty(3)
    bhi = np.empty(3)
    for c in range(6):
        q[c] = 0.0
    for c in range(3):
        blo[c] = np.inf
        bhi[c] = -np.inf
    for j in range(lo, hi):
        w = sx[3, j]
        dx = sx[0, j] - cx
        dy = sx[1, j] - cy
        dz = sx[2, j] - cz
        q[0] += w * dx * dx
        q[1] += w * dx * dy
        q[2] += w * dx * dz
        q[3] += w * dy * dy
        q[4] += w * dy * dz
        q[5] += w * dz * dz
        for c in range(3):
            v = sx[c, j]
            blo[c] = min(blo[c], v)
            bhi[c] = max(bhi[c], v)
    _store(nodes, i, m, cx, cy, cz, q, blo, bhi)


@kernel(inline=True)
def _store(nodes, i, m, cx, cy, cz, q, blo, bhi):
    nodes[i, M] = m
    nodes[i, CX] = cx
    nodes[i, CY] = cy
    nodes[i, CZ] = cz
    for c in range(6):
        nodes[i, QXX + c] = q[c]
    for c in range(3):
        nodes[i, LOX + c] = blo[c]
        nodes[i, HIX + c] = bhi[c]


@kernel(parallel=True)
def _moments(links, sx, theta, threaded):
    """nodes (K, NF): every node's moments (see the module)."""
    K = links.shape[0]
    nodes = np.empty((K, NF))
    if threaded:
        for i in numba.prange(K):
            if links[i, IS_LEAF]:
                _leaf_moments(nodes, i, links[i, LO], links[i, HI], sx)
    else:
        for i in range(K):
            if links[i, IS_LEAF]:
                _leaf_moments(nodes, i, links[i, LO], links[i, HI], sx)
    q = np.empty(6)
    blo = np.empty(3)
    bhi = np.empty(3)
    for i in range(K - 1, -1, -1):
        if links[i, IS_LEAF]:
            continue
        m = 0.0
        mx = 0.0
        my = 0.0
        mz = 0.0
        c = i + 1
        while c < links[i, NEXT]:
            w = nodes[c, M]
            m += w
            mx += w * nodes[c, CX]
            my += w * nodes[c, CY]
            mz += w * nodes[c, CZ]
            c = links[c, NEXT]
        cx = mx / m if m > 0.0 else nodes[i + 1, CX]
        cy = my / m if m > 0.0 else nodes[i + 1, CY]
        cz = mz / m if m > 0.0 else nodes[i + 1, CZ]
        for a in range(6):
            q[a] = 0.0
        for a in range(3):
            blo[a] = np.inf
            bhi[a] = -np.inf
        c = i + 1
        while c < links[i, NEXT]:
            # the parallel-axis theorem: a child's second moment moved to the parent's centre
            w = nodes[c, M]
            dx = nodes[c, CX] - cx
            dy = nodes[c, CY] - cy
            dz = nodes[c, CZ] - cz
            q[0] += nodes[c, QXX] + w * dx * dx
            q[1] += nodes[c, QXY] + w * dx * dy
            q[2] += nodes[c, QXZ] + w * dx * dz
            q[3] += nodes[c, QYY] + w * dy * dy
            q[4] += nodes[c, QYZ] + w * dy * dz
            q[5] += nodes[c, QZZ] + w * dz * dz
            for a in range(3):
                blo[a] = min(blo[a], nodes[c, LOX + a])
                bhi[a] = max(bhi[a], nodes[c, HIX + a])
            c = links[c, NEXT]
        _store(nodes, i, m, cx, cy, cz, q, blo, bhi)
    # the opening radius and 3/2 tr(Q), for the walk
    for i in range(K):
        side = 0.0
        for a in range(3):
            side = max(side, nodes[i, HIX + a] - nodes[i, LOX + a])
        r = side / theta
        nodes[i, ROPEN2] = r * r
        nodes[i, TR15] = 1.5 * (nodes[i, QXX] + nodes[i, QYY] + nodes[i, QZZ])
    return nodes


@kernel(parallel=True, by_address=True, returns=_TREE)
def build(s, theta):
    """The tree of the sources s (4, ns): x, y, z, m, for the opening angle theta:
    (sx (4, ns): the sources in tree order, order (ns,): their columns in s, links (K, 4),
    nodes (K, NF), box: (lo (3,), side, axes (3,) bool, bits))."""
    ns = s.shape[1]
    threaded = ns >= MIN_PARALLEL
    lo, side, axes, bits = _box(s)
    naxes = 0
    for c in range(3):
        naxes += 1 if axes[c] else 0
    rows = np.empty(ns, np.int64)
    for i in range(ns):
        rows[i] = i
    keys = _keys(s[0], s[1], s[2], rows, lo, side, axes, bits, threaded)
    order = arrays.radix_order(keys)
    sorted_keys = np.empty(ns, np.int64)
    sx = np.empty((4, ns))
    for i in range(ns):
        j = order[i]
        sorted_keys[i] = keys[j]
        for c in range(4):
            sx[c, i] = s[c, j]
    links = _topology(sorted_keys, naxes, bits)
    nodes = _moments(links, sx, theta, threaded)
    return sx, order, links, nodes, (lo, side, axes, bits)


# ----------------------------------------------------------------------------- the walk

@kernel(inline=True)
def _gap2(nodes, i, glo, ghi):
    """Squared distance from the group's box (glo, ghi (3,)) to node i's centre of mass."""
    d2 = 0.0
    for c in range(3):
        v = nodes[i, CX + c]
        g = glo[c] - v if v < glo[c] else (v - ghi[c] if v > ghi[c] else 0.0)
        d2 += g * g
    return d2


@kernel(inline=True)
def _overlap(nodes, i, glo, ghi):
    """Whether the group's box and node i's bounding box overlap."""
    for c in range(3):
        if glo[c] > nodes[i, HIX + c] or ghi[c] < nodes[i, LOX + c]:
            return False
    return True


@kernel(lean=True)
def _lists(links, nodes, sx, glo, ghi, cells, parts, quadrupole):
    """The group's interaction lists into cells (CELL_ROWS, cap) float32, the accepted nodes
    (com relative to the group's centre, M, Q (6), 3/2 tr Q), and parts (4, cap) float32, the
    opened leaves' sources (relative to the group's centre, m): (nc, np), or (-1, -1) when
    either is too small. Lean: an array reassigned in the walk's loop cost reference
    counts on every node visited (measured 6x the walk)."""
    nc = 0
    npart = 0
    if nodes[0, M] == 0.0:                    # an empty tree: every source was heavy
        return 0, 0
    gx = 0.5 * (glo[0] + ghi[0])
    gy = 0.5 * (glo[1] + ghi[1])
    gz = 0.5 * (glo[2] + ghi[2])
    i = 0
    K = links.shape[0]
    while i < K:
        if _gap2(nodes, i, glo, ghi) > nodes[i, ROPEN2] and not _overlap(nodes, i, glo, ghi):
            if nc == cells.shape[1]:
                return -1, -1
            cells[0, nc] = np.float32(nodes[i, CX] - gx)
            cells[1, nc] = np.float32(nodes[i, CY] - gy)
            cells[2, nc] = np.float32(nodes[i, CZ] - gz)
            cells[3, nc] = np.float32(nodes[i, M])
            if quadrupole:
                for r in range(6):
                    cells[4 + r, nc] = np.float32(nodes[i, QXX + r])
                cells[10, nc] = np.float32(nodes[i, TR15])
            else:
                for r in range(7):
                    cells[4 + r, nc] = np.float32(0.0)
            nc += 1
            i = links[i, NEXT]
        elif links[i, IS_LEAF]:
            lo = links[i, LO]
            hi = links[i, HI]
            if npart + hi - lo > parts.shape[1]:
                return -1, -1
            for j in range(lo, hi):
                parts[0, npart] = np.float32(sx[0, j] - gx)
                parts[1, npart] = np.float32(sx[1, j] - gy)
                parts[2, npart] = np.float32(sx[2, j] - gz)
                parts[3, npart] = np.float32(sx[3, j])
                npart += 1
            i = links[i, NEXT]
        else:
            i += 1
    return nc, npart


@kernel(inline=True)
def _cells_pull(xs, ys, zs, nt, cells, nc, eps2, ax, ay, az):
    """Adds to ax[t], ay[t], az[t] the acceleration / G at the points (xs[t], ys[t], zs[t]),
    t < nt (float32, relative to the group's centre, as the cells) from the accepted nodes.
    In single precision: twice the speed (eight lanes, not four), a rounding of about 1e-6
    of the force, below the tree's own error at every opening angle of docs/tree.md;
    constants are float32 so nothing widens. The points are the inner loop, so each sum
    runs in the nodes' order whatever the vector width (as pairs.pull_points)."""
    one = np.float32(1.0)
    three = np.float32(3.0)
    half15 = np.float32(7.5)
    for j in range(nc):
        cx = cells[0, j]
        cy = cells[1, j]
        cz = cells[2, j]
        m = cells[3, j]
        q0 = cells[4, j]
        q1 = cells[5, j]
        q2 = cells[6, j]
        q3 = cells[7, j]
        q4 = cells[8, j]
        q5 = cells[9, j]
        tr = cells[10, j]
        for t in range(nt):
            rx = xs[t] - cx
            ry = ys[t] - cy
            rz = zs[t] - cz
            s2 = rx * rx + ry * ry + rz * rz + eps2
            inv = one / np.sqrt(s2)          # s2 > 0: an accepted node is never at a target
            inv2 = inv * inv
            inv3 = inv * inv2
            inv5 = inv3 * inv2
            qx = q0 * rx + q1 * ry + q2 * rz
            qy = q1 * rx + q3 * ry + q4 * rz
            qz = q2 * rx + q4 * ry + q5 * rz
            rqr = rx * qx + ry * qy + rz * qz
            radial = -m * inv3 + tr * inv5 - half15 * rqr * inv5 * inv2
            ax[t] += radial * rx + three * inv5 * qx
            ay[t] += radial * ry + three * inv5 * qy
            az[t] += radial * rz + three * inv5 * qz


@kernel
def _cells_phi(x, y, z, cells, nc, eps2):
    """Potential / G at (x, y, z) (float64, relative to the group's centre) from the
    accepted nodes (float32 cells), in double precision."""
    phi = 0.0
    for j in range(nc):
        rx = x - np.float64(cells[0, j])
        ry = y - np.float64(cells[1, j])
        rz = z - np.float64(cells[2, j])
        s2 = rx * rx + ry * ry + rz * rz + eps2
        inv = 1.0 / np.sqrt(s2) if s2 > 0.0 else 0.0
        inv2 = inv * inv
        inv3 = inv * inv2
        q0, q1, q2 = np.float64(cells[4, j]), np.float64(cells[5, j]), np.float64(cells[6, j])
        q3, q4, q5 = np.float64(cells[7, j]), np.float64(cells[8, j]), np.float64(cells[9, j])
        qx = q0 * rx + q1 * ry + q2 * rz
        qy = q1 * rx + q3 * ry + q4 * rz
        qz = q2 * rx + q4 * ry + q5 * rz
        rqr = rx * qx + ry * qy + rz * qz
        # tr(Q) = TR15 / 1.5
        phi += (-np.float64(cells[3, j]) * inv - 1.5 * rqr * inv3 * inv2
                + np.float64(cells[10, j]) / 3.0 * inv3)
    return phi


@kernel(parallel=True)       # it calls _keys, which holds a prange (see _jit.kernel)
def _target_groups(tree, pos, targets, same):
    """(torder (k,): target rows in Morton order, starts (g + 1,): where each group starts in
    it, boxes (g, 6): each group's lo, hi). same: the targets are the tree's sources in their
    given order (targets[order[i]]): the groups are the largest nodes of at most GROUP
    sources; otherwise runs of at most GROUP targets in Morton order."""
    sx, order, links, nodes, box = tree
    lo, side, axes, bits = box
    k = targets.size
    torder = np.empty(k, np.int64)
    if same:
        for i in range(k):
            torder[i] = targets[order[i]]
        K = links.shape[0]
        starts = np.empty(K + 1, np.int64)
        ng = 0
        i = 0
        while i < K:
            if links[i, HI] - links[i, LO] <= GROUP or links[i, IS_LEAF]:
                starts[ng] = links[i, LO]
                ng += 1
                i = links[i, NEXT]
            else:
                i += 1
        starts[ng] = k
    else:
        keys = _keys(pos[:, 0], pos[:, 1], pos[:, 2], targets, lo, side, axes, bits, False)
        o = arrays.radix_order(keys)
        for i in range(k):
            torder[i] = targets[o[i]]
        ng = (k + GROUP - 1) // GROUP
        starts = np.empty(ng + 1, np.int64)
        for g in range(ng):
            starts[g] = g * GROUP
        starts[ng] = k
    boxes = np.empty((ng, 6))
    for g in range(ng):
        for c in range(3):
            boxes[g, c] = np.inf
            boxes[g, 3 + c] = -np.inf
        for i in range(starts[g], starts[g + 1]):
            r = torder[i]
            for c in range(3):
                boxes[g, c] = min(boxes[g, c], pos[r, c])
                boxes[g, 3 + c] = max(boxes[g, 3 + c], pos[r, c])
    return torder, starts[:ng + 1], boxes


@kernel
def _lane(lane, nlanes, sx, links, nodes, heavy, torder, starts, boxes, pos, G, eps2, quadrupole,
          out, phi):
    """The groups lane, lane + nlanes, ...: accelerations into out (n, 3), or, when phi is
    not empty, potentials into phi (n,); the heavy sources (4, nh) summed directly."""
    nh = heavy.shape[1]
    cells = np.empty((CELL_ROWS, 256), np.float32)
    parts = np.empty((4, 256), np.float32)
    eps2_32 = np.float32(eps2)
    near = stack_rows(eps2_32, 9, GROUP)
    far = stack_rows(eps2, 6, GROUP)
    for g in range(lane, boxes.shape[0], nlanes):
        glo = boxes[g, :3]
        ghi = boxes[g, 3:]
        nc, npart = _lists(links, nodes, sx, glo, ghi, cells, parts, quadrupole)
        while nc < 0:
            cells = np.empty((CELL_ROWS, 2 * cells.shape[1]), np.float32)
            parts = np.empty((4, 2 * parts.shape[1]), np.float32)
            nc, npart = _lists(links, nodes, sx, glo, ghi, cells, parts, quadrupole)
        gx = 0.5 * (glo[0] + ghi[0])
        gy = 0.5 * (glo[1] + ghi[1])
        gz = 0.5 * (glo[2] + ghi[2])
        if phi.size:
            for i in range(starts[g], starts[g + 1]):
                r = torder[i]
                x = pos[r, 0]
                y = pos[r, 1]
                z = pos[r, 2]
                # rounded as the lists are, so that a source's own term is at distance 0
                tx = np.float64(np.float32(x - gx))
                ty = np.float64(np.float32(y - gy))
                tz = np.float64(np.float32(z - gz))
                phi[r] = G * (_cells_phi(tx, ty, tz, cells, nc, eps2)
                              + pairs.potential(tx, ty, tz, parts, npart, eps2)
                              + pairs.potential(x, y, z, heavy, nh, eps2))
            continue
        # the group's targets side by side, GROUP at a time (a leaf whose sources share one
        # Morton cell may hold more): f32 rows x, y, z (from the centre), the cells' sums,
        # the particles' sums; f64 rows x, y, z, the heavy sources' sums
        for t0 in range(starts[g], starts[g + 1], GROUP):
            nt = min(GROUP, starts[g + 1] - t0)
            for t in range(nt):
                r = torder[t0 + t]
                near[0, t] = np.float32(pos[r, 0] - gx)
                near[1, t] = np.float32(pos[r, 1] - gy)
                near[2, t] = np.float32(pos[r, 2] - gz)
                for c in range(3, 9):
                    near[c, t] = np.float32(0.0)
                far[0, t] = pos[r, 0]
                far[1, t] = pos[r, 1]
                far[2, t] = pos[r, 2]
                for c in range(3, 6):
                    far[c, t] = 0.0
            _cells_pull(near[0], near[1], near[2], nt, cells, nc, eps2_32, near[3], near[4],
                        near[5])
            pairs.pull_points(near[0], near[1], near[2], nt, parts, npart, eps2_32, near[6],
                              near[7], near[8])
            pairs.pull_points(far[0], far[1], far[2], nt, heavy, nh, eps2, far[3], far[4],
                              far[5])
            for t in range(nt):
                r = torder[t0 + t]
                for c in range(3):
                    out[r, c] = G * (np.float64(near[3 + c, t]) + np.float64(near[6 + c, t])
                                     + far[3 + c, t])


@kernel(parallel=True, by_address=True, returns=types.none)
def walk(tree, heavy, pos, targets, same, G, eps2, quadrupole, out, phi, threaded):
    """out[k] = G * the pull of the tree and of the heavy sources (4, nh) on pos[k] for k in
    targets (or phi[k] = G * their potential, phi (n,) not empty); on threads when
    `threaded` and there are enough targets."""
    torder, starts, boxes = _target_groups(tree, pos, targets, same)
    sx, _, links, nodes, _ = tree
    ng = boxes.shape[0]
    if threaded and targets.size >= MIN_PARALLEL:
        nl = min(LANES, ng)
        for lane in numba.prange(nl):
            # (a prange index is unsigned: as int64, _lane is compiled once)
            _lane(np.int64(lane), nl, sx, links, nodes, heavy, torder, starts, boxes, pos, G,
                  eps2, quadrupole, out, phi)
    else:
        _lane(0, 1, sx, links, nodes, heavy, torder, starts, boxes, pos, G, eps2, quadrupole,
              out, phi)


@kernel
def split(s):
    """(heavy (4, nh), light (4, nl), is_heavy (ns,) bool): the sources of more than HEAVY of the total mass (a
    planet among its ring, a galaxy's core: at most 1 / HEAVY of them), summed directly so
    that their pull is exact, and the others, which the tree holds."""
    total = 0.0
    for j in range(s.shape[1]):
        total += s[3, j]
    nh = 0
    for j in range(s.shape[1]):
        nh += 1 if s[3, j] > HEAVY * total else 0
    heavy = np.empty((4, nh))
    light = np.empty((4, s.shape[1] - nh))
    is_heavy = np.empty(s.shape[1], np.bool_)
    a = 0
    b = 0
    for j in range(s.shape[1]):
        is_heavy[j] = s[3, j] > HEAVY * total
        if is_heavy[j]:
            for c in range(4):
                heavy[c, a] = s[c, j]
            a += 1
        else:
            for c in range(4):
                light[c, b] = s[c, j]
            b += 1
    return heavy, light, is_heavy


@kernel(parallel=True, by_address=True)
def accelerations(s, src, targets, pos, G, eps2, theta, quadrupole, out, threaded):
    """out[k] = G * the pull of the sources s (4, ns) (the rows src of pos) on pos[k] for k in
    targets: the heavy ones directly, the others through a tree built for it."""
    heavy, light, _ = split(s)
    tree = build(light, theta)
    # the targets are the tree's sources in order: its nodes make the groups
    same = targets.size == src.size and heavy.shape[1] == 0
    if same:
        for i in range(src.size):
            if targets[i] != src[i]:
                same = False
                break
    walk(tree, heavy, pos, targets, same, G, eps2, quadrupole, out, np.empty(0), threaded)


def _tree_pull(model, tape, src, passive, pos, mass, out, targets, threads):
    """The model's pull (kernels/gravity.pull): a tree of the sources built and walked; a
    prediction's tape never runs with the tree."""
    s = model.sources
    gather(src, pos, mass, s)
    accelerations(s, src, targets, pos, model.G, model.eps2, model.theta, model.quadrupole,
                  out, gravity.threaded(threads, targets.size * s.shape[1]))


@kernel(parallel=True)
def tree_potential(model, pos, mass, src, passive):
    """The potential energy as the tree's forces see it: the light sources' pairs from the
    tree's potential (1/2 m_i phi_i), every pair with a heavy source (split) summed directly,
    and the rows `passive` of mass > 0 in the sources' field."""
    s = np.empty((4, src.size))
    gather(src, pos, mass, s)
    heavy, light, is_heavy = split(s)
    k = 0
    for a in range(src.size):
        k += 0 if is_heavy[a] else 1
    for a in range(passive.size):
        k += 1 if mass[passive[a]] != 0.0 else 0
    rows = np.empty(k, np.int64)          # the light sources, then the passive rows
    k = 0
    for a in range(src.size):
        if not is_heavy[a]:
            rows[k] = src[a]
            k += 1
    nlight = k
    for a in range(passive.size):
        if mass[passive[a]] != 0.0:
            rows[k] = passive[a]
            k += 1
    phi = np.empty(mass.size)
    t = build(light, model.theta)
    walk(t, np.empty((4, 0)), pos, rows, False, 1.0, model.eps2, model.quadrupole,
         np.empty((0, 3)), phi, True)
    total = 0.0
    c = 0.0
    nh = heavy.shape[1]
    for a in range(rows.size):
        i = rows[a]
        near = pairs.potential(pos[i, 0], pos[i, 1], pos[i, 2], heavy, nh, model.eps2)
        total, c = add(total, c, mass[i] * ((0.5 if a < nlight else 1.0) * phi[i] + near))
    for a in range(src.size):
        if is_heavy[a]:
            i = src[a]
            near = pairs.potential(pos[i, 0], pos[i, 1], pos[i, 2], heavy, nh, model.eps2)
            total, c = add(total, c, 0.5 * mass[i] * near)
    return model.G * (total + c)


def _tree_potential_exact(model, pos, mass, src, passive):
    return gravity.mutual_potential(model.G, model.eps2, pos, mass, src, passive)


def _tree_energies(model, pos, vel, mass, src, out):
    gravity.mutual_body_energies(model.G, model.eps2, pos, vel, mass, src, out)


gravity.register(Tree, gravity.Model("tree", _tree_potential_exact, _tree_energies,
                                     tree_potential), _tree_pull, parallel=True, counted=True)
