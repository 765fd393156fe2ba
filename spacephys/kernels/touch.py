"""The pairs in touch: sensor pairs overlapping and contact pairs (elastic, bounce) touching at
the end of each step, and their begin and end events (sensor_begin/end, contact_begin/end).
"""
import math

import numpy as np
from numba import types

from .._jit import kernel
from .codes import (BOUNCE, ELASTIC, EV_CONTACT_BEGIN, EV_CONTACT_END, EV_SENSOR_BEGIN,
                    EV_SENSOR_END, SENSOR)
from .arrays import contact_order, stable_order
from . import shapes as kshapes
from .impact import exit_time
from .rules import allowed, wrap
from .state import record, row_of

# bodies in contact (elastic, bounce) are touching while the gap between their surfaces is at
# most this fraction of the sum of their radii: a resting body's gap after its bounce is
# rounding, a settling one's e g dt^2; a visible gap is a separation
CONTACT_SLOP = 1e-4
@kernel
def _touch_event(state, rules, kind, i, j, t, dt, t0, L, shapes):
    """Record a begin or end event of rows i, j at fraction t of the step, from their lines:
    the contact point on i's surface, the unit normal i -> j, the closing speed, the centre
    distance (compound bodies: of the circles closest to touching, which it names)."""
    A, B = rules.A, rules.B
    pi = np.empty(3)
    n = np.empty(3)
    for c in range(3):
        pi[c] = A[i, c] + B[i, c] * t
        n[c] = wrap(A[j, c] + B[j, c] * t - pi[c], L[c])
    dist = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    closing = 0.0
    for c in range(3):
        n[c] = n[c] / dist if dist > 0.0 else (1.0 if c == 0 else 0.0)
        closing -= (B[j, c] - B[i, c]) * n[c] / dt
    point = np.empty(3)
    for c in range(3):
        point[c] = pi[c] + n[c] * rules.radius[i]
    first = state.count[0]
    if shapes is not None:
        if shapes.shape[i] >= 0 or shapes.shape[j] >= 0:
            pj = np.empty(3)
            ui = np.empty(3)
            uj = np.empty(3)
            for c in range(3):
                pj[c] = pi[c] + n[c] * dist if dist > 0.0 else pi[c]
                ui[c] = B[i, c] / dt
                uj[c] = B[j, c] / dt
            dist, closing = kshapes.contact(shapes, i, j, t, pi, pj, ui, uj, rules.radius, n,
                                            point)
            closing = -closing
    record(state, kind, state.ids[i], state.ids[j], t0 + t * dt, t * dt, point, n, closing,
           0.0, dist)
    kshapes.name(shapes, state, first)


@kernel(by_address=True, returns=types.none)
def touches(state, rules, dt, t0, L, shapes):
    """The step's begin and end events, and the pairs in touch at its end (rules.touch).

    A sensor pair is in touch while the bodies overlap: sensor_begin when it starts (its
    meeting in the step, or the step's start for one that overlapped without moving in),
    sensor_end when it stops (the later root of the step's last line; when a body went: then)
    -- both in one step for a body that passes through. A contact pair (elastic, bounce) is in
    touch while the gap is within CONTACT_SLOP: contact_begin at the bounce of a step that
    ends touching and would a step later, contact_end at the step that ends apart (a clean bounce
    is a bounce only). Appended after the step's other events, in time order (then by the
    pair's ids; a pair's body a is the one of the lower id)."""
    ids, alive, kind = state.ids, state.alive, rules.kind
    A, B, tb, radius = rules.A, rules.B, rules.tb, rules.radius
    P = rules.ntouch[0]
    F = rules.nfound[0]
    m = P + F
    ci = np.empty(m, np.int64)
    cj = np.empty(m, np.int64)
    ct = np.empty(m)
    cwas = np.zeros(m, np.int64)             # 0: met now; 1: a sensor pair in touch; 2: a contact
    ka = np.empty(m, np.int64)               # the pair's ids, lower first: its sort keys
    kb = np.empty(m, np.int64)
    ev_kind = np.empty(2 * m, np.int64)      # the events, sorted by time before recording
    ev_i = np.empty(2 * m, np.int64)
    ev_j = np.empty(2 * m, np.int64)
    ev_t = np.empty(2 * m)
    ne = 0
    k = 0
    for p in range(P):
        i = row_of(rules.index, ids, rules.touch[p, 0])
        j = row_of(rules.index, ids, rules.touch[p, 1])
        if i < 0 or j < 0:
            # a body removed between steps: its pair ends at this step's start
            point = np.zeros(3)
            record(state, EV_SENSOR_END if rules.touch[p, 2] else EV_CONTACT_END,
                   rules.touch[p, 0], rules.touch[p, 1], t0, 0.0, point, point, 0.0, 0.0, 0.0)
            continue
        ci[k], cj[k] = (i, j) if ids[i] < ids[j] else (j, i)
        ct[k] = np.inf
        cwas[k] = 1 if rules.touch[p, 2] else 2
        k += 1
    for f in range(F):
        i, j = rules.found[f, 0], rules.found[f, 1]
        ci[k], cj[k] = (i, j) if ids[i] < ids[j] else (j, i)
        ct[k] = rules.found_t[f]
        k += 1
    for q in range(k):
        ka[q] = ids[ci[q]]
        kb[q] = ids[cj[q]]
    order = contact_order(np.zeros(k), ka, kb, k)    # (by ids: the contacts' compiled sort)
    nt = 0
    q = 0
    while q < k:
        # one pair: its entries side by side
        first = order[q]
        i, j = ci[first], cj[first]
        was = 0
        t_in = np.inf
        while q < k and ka[order[q]] == ka[first] and kb[order[q]] == kb[first]:
            e = order[q]
            was = max(was, cwas[e])
            t_in = min(t_in, ct[e])
            q += 1
        resp = allowed(rules, kind, i, j)
        sensor = was == 1 if was else resp == SENSOR
        R = radius[i] + radius[j]
        reach = R if sensor else R * (1.0 + CONTACT_SLOP)
        live = alive[i] and alive[j]
        now = False
        compound = False
        if shapes is not None:
            compound = shapes.shape[i] >= 0 or shapes.shape[j] >= 0
        if live and (resp == SENSOR if sensor else (resp == ELASTIC or resp == BOUNCE)) \
                and compound:
            slop = reach - R                     # a gap of circles, not of centres
            if shapes is not None:
                now = kshapes.gap(shapes, A, B, i, j, 1.0, L, radius) <= slop and \
                    (sensor or was > 0 or kshapes.gap(shapes, A, B, i, j, 2.0, L, radius) <= slop)
        elif live and (resp == SENSOR if sensor else (resp == ELASTIC or resp == BOUNCE)):
            d2 = 0.0
            ahead = 0.0
            for c in range(3):
                d = wrap(A[j, c] + B[j, c] - A[i, c] - B[i, c], L[c])
                d2 += d * d
                ahead += (d + B[j, c] - B[i, c]) ** 2
            # a contact begins resting: still touching a step later on its line (not a bounce
            # at the step's very end, parting)
            now = d2 <= reach * reach and (sensor or was > 0 or ahead <= reach * reach)
        if now:
            if nt >= rules.touch.shape[0]:
                grown = np.empty((2 * nt + 16, 3), np.int64)
                for r in range(nt):
                    for c in range(3):
                        grown[r, c] = rules.touch[r, c]
                rules.touch = grown
            a, b = ids[i], ids[j]
            rules.touch[nt, 0] = min(a, b)
            rules.touch[nt, 1] = max(a, b)
            rules.touch[nt, 2] = 1 if sensor else 0
            nt += 1
        begins = not was and (now or sensor)
        if begins:
            ev_kind[ne] = EV_SENSOR_BEGIN if sensor else EV_CONTACT_BEGIN
            ev_i[ne], ev_j[ne] = i, j
            ev_t[ne] = t_in if t_in < np.inf else 0.0
            ne += 1
        if not now and (was or begins):
            if not live:
                t_out = tb[j] if not alive[j] and (alive[i] or tb[j] < tb[i]) else tb[i]
            elif compound:
                t_out = tb[i]
                if shapes is not None:
                    t_out = kshapes.exit_time(shapes, A, B, tb, i, j, reach - R,
                                              t_in if t_in < np.inf else 0.0, L, radius)
            else:
                t_out = exit_time(A, B, tb, i, j, reach, t_in if t_in < np.inf else 0.0, L)
            ev_kind[ne] = EV_SENSOR_END if sensor else EV_CONTACT_END
            ev_i[ne], ev_j[ne] = i, j
            ev_t[ne] = t_out
            ne += 1
    rules.ntouch[0] = nt
    rules.ntouch[1] = rules.touch.shape[0]
    rank = stable_order(ev_t, ne)
    for r in range(ne):
        e = rank[r]
        _touch_event(state, rules, ev_kind[e], ev_i[e], ev_j[e], ev_t[e], dt, t0, L, shapes)
