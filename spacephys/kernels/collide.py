"""The collision pass of a step: every contact found and resolved, in time order.

Following the steps of analysis of Basic Game Physics (Laird & Jamin), for every pair at once:
over a step each body moves on the straight line from its start to its end position,
p(t) = A + B t, t in [0, 1] of the step.
1. Broad phase (kernels/broadphase.py): the pairs whose swept boxes overlap.
2. Narrow phase (kernels/impact.py): the earliest t at which each pair, and each body and a
   wall, touch.
3. Contacts are resolved in time order (at one time in the order of the bodies' ids, so the
   outcome depends neither on the grid nor on the rows the bodies hold: a pair's body a is
   the one of the lower id) by the responses (kernels/responses.py). A body takes one contact per
   pass; passes repeat until no contact is left (each looks only the bodies whose lines
   changed up in the first pass's grid, testing those changed since directly), and a last
   pass makes sure no pair ends the step overlapping and approaching.
4. The pairs in touch and their begin and end events (kernels/touch.py).
The table is kernels/rules.Rules.
"""
import numpy as np
from numba import types

from .._jit import kernel
from .arrays import contact_order, sort_in_place
from .broadphase import focused_pairs, grid_pairs
from . import shapes as kshapes
from .codes import MERGE, PLANE, REFLECT, SENSOR, TOUCH_ENDS, UNTOUCHED
from .impact import pair_time, wall_time
from .responses import met, respond, respond_wall, survivor
from .rules import allowed, periods, wrap
from .touch import touches

_MAX_PASSES = 32


@kernel(by_address=True, returns=types.int64)
def collide_step(state, rules, dt, t0):
    """Find and resolve every contact of one step, in time order.

    state : the kernels' State: pos0, vel0 hold the positions and velocities at the start of
    the step (vel0 is used as scratch: merges overwrite it); pos, vel those at its end,
    updated where a contact changed them, left bit for bit as they were elsewhere (a contact
    at fraction t of the step sees the velocity interpolated between the two); mass is
    updated by merges (bodies destroyed or merged away get mass 0 and are marked dead in
    state.alive); events are appended to its buffer. rules : Rules; dt : the step [time];
    t0 : the simulation time at its start.
    Returns BODIES_GONE if a body was removed or merged, DEFLECTED if only velocities
    changed, UNTOUCHED if nothing (kernels/codes.py).
    """
    pos0, vel0, pos, vel, mass = state.pos0, state.vel0, state.pos, state.vel, state.mass
    radius, kind, alive, ids = rules.radius, rules.kind, state.alive, state.ids
    n = pos.shape[0]
    L = periods(rules)
    A, B, D, lo, hi, tb = rules.A, rules.B, rules.D, rules.lo, rules.hi, rules.tb
    ever, touched, in_focus, is_giant = rules.ever, rules.touched, rules.in_focus, rules.is_giant
    merged_into = rules.merged
    shapes = rules.shapes
    # (a loop per array: one loop writing them all took twice as long, 0.45 against 0.23 ms
    # for 6e4 bodies)
    tb[:] = 0.0
    ever[:] = False
    touched[:] = False
    in_focus[:] = False
    is_giant[:] = False
    D[:] = 0.0
    for i in range(n):
        merged_into[i] = i
    for i in range(n):
        for c in range(3):
            A[i, c] = pos0[i, c]
            # where periodic, the start is unwrapped next to the end the integrator reached
            B[i, c] = wrap(pos[i, c] - pos0[i, c], L[c]) if L[c] > 0.0 else pos[i, c] - pos0[i, c]
    # D: impulses of this step, per body; ever: bodies whose line a contact changed
    V0 = vel0                                          # merges mix these in place
    V1 = vel
    walls = rules.walls
    nbox = 2 * rules.dim if rules.boundary == REFLECT else 0
    box_walls = np.zeros((nbox, 8))
    for c in range(nbox // 2):
        for side in range(2):
            row = box_walls[2 * c + side]
            row[0] = PLANE
            row[1 + c] = rules.box[side, c]
            row[4 + c] = 1.0 if side == 0 else -1.0
            row[7] = rules.box_restitution
    result = UNTOUCHED
    # merged_into: a body merged away hands its remaining contacts of the step to its
    # survivor, so that everything that touched within the step ends up one body (merges
    # chain transitively)
    for q in range(rules.giants.size):
        is_giant[rules.giants[q]] = True
    # stale: the bodies whose lines changed since the grid was built (its entries for them
    # are out of date), listed in changed[:nc]; moved[:nm]: the bodies touched in the pass
    # (lists, not loops over every body: a pass after the first sees a few hundred)
    stale = rules.stale
    changed = np.empty(n, np.int64)
    moved = np.empty(n, np.int64)
    nc = 0
    nm = 0
    focus = moved[:0]
    rules.nfound[0] = 0
    for sweep in range(_MAX_PASSES + 1):
        last = sweep == _MAX_PASSES
        if sweep == 0:
            pairs, grid = grid_pairs(A, B, tb, alive, rules, lo, hi)
            for i in range(n):
                stale[i] = False
        else:
            # only pairs with a body whose line changed in the last pass can be new: those
            # bodies look the others up in the grid (10^5 bodies: a new grid took 21 ms)
            for q in range(focus.size):
                in_focus[focus[q]] = False
            focus = moved[:nm].copy()
            sort_in_place(focus, nm)
            for q in range(focus.size):
                i = focus[q]
                in_focus[i] = True
                if not stale[i]:
                    stale[i] = True
                    changed[nc] = i
                    nc += 1
            pairs, ok = focused_pairs(A, B, tb, alive, rules, lo, hi, focus, in_focus,
                                      stale, changed[:nc], grid, is_giant)
            if not ok:                                 # too many changed: a new grid
                pairs, grid = grid_pairs(A, B, tb, alive, rules, lo, hi)
                for q in range(nc):
                    stale[changed[q]] = False
                nc = 0
        _by_id(pairs, ids)
        pt, pi_, pj_ = pair_contacts(A, B, tb, pairs, L, rules, shapes)
        # contacts: (time, i, j) with j < 0 for walls (-1 - row; box walls after the walls);
        # after the first pass only the bodies whose lines changed can meet a wall anew
        k = pt.size
        nw = walls.shape[0] + nbox
        rows = n if sweep == 0 else focus.size
        ct = np.empty(k + rows * nw)
        ci = np.empty(ct.size, np.int64)
        cj = np.empty(ct.size, np.int64)
        cn = np.empty((ct.size, 4))              # a wall's normal, the circle touching
        for q in range(k):
            ct[q] = pt[q]
            ci[q] = pi_[q]
            cj[q] = pj_[q]
        for q in range(rows if nw else 0):
            i = q if sweep == 0 else focus[q]
            if not alive[i]:
                continue
            for w in range(nw):
                row = walls[w] if w < walls.shape[0] else box_walls[w - walls.shape[0]]
                t, n0, n1, n2, circ = wall_contact(shapes, A, B, i, radius, row, tb[i])
                if t >= 0.0:
                    ct[k] = t
                    ci[k] = i
                    cj[k] = -1 - w
                    cn[k, 0] = n0
                    cn[k, 1] = n1
                    cn[k, 2] = n2
                    cn[k, 3] = circ
                    k += 1
        if k == 0:
            break
        # (ids in place of rows: walls' negative codes stay as they are)
        ki = np.empty(k, np.int64)
        kj = np.empty(k, np.int64)
        for q in range(k):
            ki[q] = ids[ci[q]]
            kj[q] = ids[cj[q]] if cj[q] >= 0 else cj[q]
        order = contact_order(ct, ki, kj, k)
        for q in range(nm):
            touched[moved[q]] = False
        nm = 0
        for q in range(k):
            c = order[q]
            i = survivor(merged_into, ci[c])
            j = cj[c] if cj[c] < 0 else survivor(merged_into, cj[c])
            if i == j or not alive[i] or (j >= 0 and not alive[j]):
                continue
            if j >= 0 and ids[i] > ids[j]:
                i, j = j, i
            chained = j >= 0 and allowed(rules, kind, i, j) == MERGE
            if not chained and (touched[i] or (j >= 0 and touched[j])):
                continue
            t = max(ct[c], tb[i], tb[j] if j >= 0 else 0.0)
            first = state.count[0]
            if last:
                t = 1.0                  # out of passes: respond at the end, no more lines
            if j < 0:
                w = -1 - j
                row = walls[w] if w < walls.shape[0] else box_walls[w - walls.shape[0]]
                r = respond_wall(i, t, cn[c, 0], cn[c, 1], cn[c, 2], row[7], A, B, tb, V0, V1,
                                  D, mass, radius, ids, rules, dt, t0, state, int(cn[c, 3]),
                                  shapes)
            else:
                resp = allowed(rules, kind, i, j)
                if resp == SENSOR and sweep > 0 and met(rules, i, j):
                    continue
                r = respond(i, j, t, resp, rules.restitution[kind[i], kind[j]], A, B, tb,
                             V0, V1, D, mass, radius, alive, ids, rules, dt, t0, L, state,
                             shapes)
                if resp == MERGE:
                    merged_into[i if not alive[i] else j] = j if not alive[i] else i
            kshapes.name(shapes, state, first)
            if r != UNTOUCHED:
                for body in (i, j):
                    if body >= 0 and not touched[body]:
                        touched[body] = True
                        ever[body] = True
                        moved[nm] = body
                        nm += 1
                result = max(result, r)
        if nm == 0:
            break
    if rules.ntouch[0] or rules.nfound[0]:
        touches(state, rules, dt, t0, L, shapes)
    wraps = L[0] > 0.0 or L[1] > 0.0 or L[2] > 0.0
    for i in range(n):
        if not (ever[i] or wraps):
            continue                                   # untouched: the integrator's state
        for c in range(3):
            x = A[i, c] + B[i, c] if ever[i] else pos[i, c]
            if L[c] > 0.0:
                x = rules.box[0, c] + (x - rules.box[0, c]) % L[c]
            pos[i, c] = x
            if ever[i]:
                vel[i, c] = V1[i, c] + D[i, c]
    return result


@kernel(lean=True)
def _by_id(pairs, ids):
    """Each pair (m, 2) of rows as (the lower id's, the higher id's), in place."""
    for q in range(pairs.shape[0]):
        if ids[pairs[q, 0]] > ids[pairs[q, 1]]:
            i = pairs[q, 0]
            pairs[q, 0] = pairs[q, 1]
            pairs[q, 1] = i


@kernel
def pair_contacts(A, B, tb, pairs, L, rules, shapes):
    """Narrow phase: (times, i, j) of the candidate pairs that touch within the step
    (compound shapes circle by circle: kernels/shapes.py)."""
    radius = rules.radius
    m = pairs.shape[0]
    ct = np.empty(m)
    ci = np.empty(m, np.int64)
    cj = np.empty(m, np.int64)
    k = 0
    for q in range(m):
        i = pairs[q, 0]
        j = pairs[q, 1]
        resp = allowed(rules, rules.kind, i, j)
        overlap = resp in TOUCH_ENDS or resp == SENSOR
        t_lo = max(tb[i], tb[j])
        if shapes is not None:
            if shapes.shape[i] >= 0 or shapes.shape[j] >= 0:
                t = kshapes.pair_time(shapes, A, B, i, j, radius, t_lo, L, overlap)
            else:
                t = pair_time(A, B, i, j, radius[i] + radius[j], t_lo, L, overlap)
        else:
            t = pair_time(A, B, i, j, radius[i] + radius[j], t_lo, L, overlap)
        if t >= 0.0:
            ct[k] = t
            ci[k] = i
            cj[k] = j
            k += 1
    return ct[:k], ci[:k], cj[:k]


@kernel
def wall_contact(shapes, A, B, i, radius, wall, t_lo):
    """impact.wall_time, and the circle of a compound body that touches (-1: round)."""
    if shapes is not None:
        if shapes.shape[i] >= 0:
            return kshapes.wall_time(shapes, A, B, i, radius, wall, t_lo)
    t, n0, n1, n2 = wall_time(A, B, i, radius[i], wall, t_lo)
    return t, n0, n1, n2, -1
