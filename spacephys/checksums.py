"""CRC-32 of every row a run log holds, per flush: a flipped byte anywhere in the data is an
error (Run.verify, sp.replay), not a number.

Raw (uncompressed) tables carry no checksum of their own: HDF5's Fletcher-32 covers a whole
chunk, which a kill can tear while a raw chunk is rewritten in place. Instead each time the
writer makes rows durable it appends one row to /flushes: `lengths` (LENGTHS: the tables' row
counts after it) and `crc` (one CRC-32 per table of CHECKED, of the rows added since the
previous flush row, zlib's polynomial). A flush row is written before the /commit that counts
its rows, so a kill leaves at most one flush row past the commit, which readers ignore.
"""
import zlib

import numpy as np

# the row counts a flush row records: /commit's counts, then the bytes used in inputs/text
# and checkpoints/image
LENGTHS = ("frames", "rows", "layouts", "layout_rows", "events", "inputs", "checkpoints",
           "text", "image")
# every table of the log and the count of its rows
CHECKED = tuple([(f"frames/{name}", "frames") for name in ("step", "t", "first", "count",
                                                              "layout")] +
                [("frames/pos", "rows"), ("frames/vel", "rows"),
                 ("layouts/first", "layouts"), ("layouts/count", "layouts")] +
                [(f"layouts/{name}", "layout_rows") for name in ("ids", "mass", "radius",
                                                                   "kind")] +
                [("events", "events")] +
                [(f"inputs/{name}", "inputs") for name in ("step", "t", "first", "size")] +
                [("inputs/text", "text"), ("checkpoints/table", "checkpoints"),
                 ("checkpoints/image", "image")])
COLUMN = {name: LENGTHS.index(count) for name, count in CHECKED}


def crc(rows, value=0):
    """CRC-32 of an array's bytes as stored (C order), continuing from `value`."""
    return zlib.crc32(np.ascontiguousarray(rows), value)


def create(f):
    """The /flushes tables of a new log (raw, like the tables they check)."""
    g = f.create_group("flushes")
    for name, width in (("lengths", len(LENGTHS)), ("crc", len(CHECKED))):
        g.create_dataset(name, (0, width), np.int64, maxshape=(None, width),
                         chunks=(256, width))


def valid(f, counts):
    """(lengths (K, 9), crc (K, 21)) of the flush rows within the committed `counts` (a dict
    of the COUNTS, or of LENGTHS): those a writer made before its last commit."""
    g = f["flushes"]
    lengths, crcs = g["lengths"][:], g["crc"][:]
    limit = np.array([counts.get(name, np.iinfo(np.int64).max) for name in LENGTHS])
    within = np.all(lengths <= limit, axis=1)
    k = int(np.argmin(within)) if not within.all() else within.size   # the prefix
    return lengths[:k], crcs[:k]


def carry(f, start, end):
    """{table: CRC-32} of the rows between two sets of LENGTHS (a resumed log's rows after
    its last kept flush row: the next flush row covers them too)."""
    out = {}
    for name, count in CHECKED:
        a, b = int(start[COLUMN[name]]), int(end[COLUMN[name]])
        if b > a:
            out[name] = crc(f[name][a:b])
    return out


def verify(f, path, counts, error):
    """Check every committed row of the log open in `f` against its flush row; raise
    error(message naming the file, the table and the rows) at the first mismatch. Returns
    the number of flush rows checked (0: a log written before checksums, nothing checked).
    Every commit is made with a flush row of the same lengths: flush rows that stop short of
    the committed rows are damage too."""
    if "flushes" not in f:
        return 0
    lengths, crcs = valid(f, counts)
    reach = lengths[-1, :len(LENGTHS) - 2] if lengths.shape[0] else np.zeros(len(LENGTHS) - 2, np.int64)
    want = [counts[name] for name in LENGTHS[:-2]]
    if not np.array_equal(reach, want):
        raise error(f"{path!r}: corrupt: the flush rows reach {reach.tolist()} rows "
                    f"({', '.join(LENGTHS[:-2])}), the commit counts {want}")
    for k, j, name, a, b in blocks(lengths):
        if crc(f[name][a:b]) != crcs[k, j]:
            raise error(f"{path!r}: corrupt: {name} rows {a} to {b - 1} do not match "
                        f"the CRC-32 written with them (flush {k})")
    return lengths.shape[0]


def blocks(lengths):
    """(flush k, table index j in CHECKED, table name, first row, end row) of every
    non-empty run of rows the flush rows `lengths` (K, 9) cover, in order."""
    start = np.zeros(len(LENGTHS), np.int64)
    for k in range(lengths.shape[0]):
        for j, (name, _) in enumerate(CHECKED):
            a, b = int(start[COLUMN[name]]), int(lengths[k, COLUMN[name]])
            if b > a:
                yield k, j, name, a, b
        start = lengths[k]
