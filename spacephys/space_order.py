"""Bodies stored in space order: every EVERY steps a large colliding scene puts its rows in
Z-order (the Morton order of their positions), so that the broad phase, whose grid is read in
the same order (kernels/broadphase.py), and the narrow phase read nearby bodies from nearby
memory. Among 10^5 circles and more the bodies' columns fall out of the cache; in creation
order each pair's reads are random.

Sorting never changes a result: ids are kept, and whatever the physics orders by is ordered
by ids, not rows (the contacts at one time, a pair's bodies a and b, the pairs in touch, the
bodies that die in a step and the slots they free). It applies only where nothing else
depends on rows: collisions, no sum over bodies (gravity "none", "uniform" or "central"), a
family whose steps are each body's own (steppers.Capabilities.rows_free: splitting, rk), no
ships, missiles, lifetimes, tethers, rails, user forces or prediction tape (Driver.sorts
says which). The order is a function of the positions and ids alone, taken before each
kernel call whose steps pass a multiple of EVERY (calls are not split for it, so the times
of events are those of a World that never sorts), so a restored or replayed World making the
same calls sorts where the original did. What a user sees move are the rows of w.pos and the
like (named by w.ids, as after a removal).
"""
from .kernels import morton as kmorton

# steps between sorts, and the fewest bodies a sort is for (docs/performance.md: below about
# 5e4 circles the columns stay in the cache, and sorting gains nothing)
EVERY = 64
MIN_BODIES = 50_000


def order(pos, ids):
    """(n,) int64: the rows of pos (n, 3) in Morton order of their positions, rows at one
    code by id (kernels/morton.order); None when a position is not finite."""
    rows = kmorton.order(pos, ids)
    return rows if rows.size == pos.shape[0] else None
