"""Who writes an HDF5 file, and clearing what a killed writer left in its superblock.

A file written in SWMR mode (HDF5 >= 1.10, superblock version 3) carries "file consistency
flags" in its superblock while a writer has it open; HDF5 refuses a plain open while they are
set, so a file whose writer was killed needs them cleared (the job of HDF5's h5clear tool,
which pip's h5py does not ship). A run log names its writer (process id and start time);
when that process is gone, clear_flags resets the flags.

Superblock version 3 (HDF5 File Format Specification, "Superblock Version 2 and 3"): the
8-byte signature, version, size of offsets, size of lengths, the flags byte, four addresses
of `size of offsets` bytes each, then a Jenkins lookup3 checksum of everything before it.
"""
import os

SIGNATURE = b"\x89HDF\r\n\x1a\n"
_M = 0xFFFFFFFF


def writer_id():
    """(pid, start): this process, its start time in clock ticks since boot (0 where /proc
    is not there)."""
    return os.getpid(), _start_time(os.getpid())


def alive(pid, start):
    """Is the process (pid, start) of writer_id() still running on this machine?"""
    if pid <= 0:
        return False
    now = _start_time(pid)
    if now is None:
        return False
    return start == 0 or now == start


def _start_time(pid):
    """A process's start time (clock ticks since boot), 0 if /proc is absent, None if the
    process is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            # the command name may hold spaces and parentheses: fields count from its end
            return int(f.read().rsplit(")", 1)[1].split()[19])
    except FileNotFoundError:
        if os.path.isdir("/proc"):
            return None
    except (OSError, IndexError, ValueError):
        pass
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return None
    except PermissionError:
        pass
    return 0


def flags_set(path):
    """True if the superblock of `path` (version 3, at the start of the file) has its
    consistency flags set: a writer has it open, or died with it open."""
    with open(path, "rb") as f:
        head = f.read(12)
    return len(head) == 12 and head[:8] == SIGNATURE and head[8] == 3 and head[11] != 0


def clear_flags(path):
    """Reset the consistency flags a killed writer left, and its end-of-file address to the
    file's size if that is larger (and the superblock's checksum).
    Returns False, changing nothing, unless the file starts with a version-3 superblock whose
    checksum is right."""
    with open(path, "r+b") as f:
        head = f.read(12)
        if len(head) < 12 or head[:8] != SIGNATURE or head[8] != 3:
            return False
        size = 12 + 4 * head[9]
        block = bytearray(head + f.read(size - 12 + 4))
        if len(block) != size + 4 or hashlittle(bytes(block[:size])) != \
                int.from_bytes(block[size:], "little"):
            return False
        block[11] = 0
        # the end-of-file address: a writer killed between flushing a chunk's index and the
        # superblock leaves it short of data the index points to (written: the file is
        # longer); HDF5 refuses to read past it
        width = head[9]
        at = 12 + 2 * width
        stored = int.from_bytes(block[at:at + width], "little")
        actual = os.fstat(f.fileno()).st_size
        if actual > stored:
            block[at:at + width] = actual.to_bytes(width, "little")
        block[size:] = hashlittle(bytes(block[:size])).to_bytes(4, "little")
        f.seek(0)
        f.write(block)           # one write of some 48 bytes: a kill cannot split it
    return True


def _rot(x, k):
    return ((x << k) | (x >> (32 - k))) & _M


def hashlittle(data, initval=0):
    """Bob Jenkins' lookup3 hash ("hashlittle", 1996-2006, public domain): the checksum of
    HDF5's metadata. bytes -> uint32."""
    n = len(data)
    a = b = c = (0xDEADBEEF + n + initval) & _M
    tail = n - 1 - (n - 1) % 12 if n else 0        # the last 1..12 bytes go to the final mix
    padded = data + bytes(12)
    for i in range(0, tail + 12 if n else 0, 12):
        a = (a + int.from_bytes(padded[i:i + 4], "little")) & _M
        b = (b + int.from_bytes(padded[i + 4:i + 8], "little")) & _M
        c = (c + int.from_bytes(padded[i + 8:i + 12], "little")) & _M
        if i < tail:
            # mix: x -= z; x ^= rot(z, k); z += y, the roles turning (a, b, c) -> (b, c, a)
            for k in (4, 6, 8, 16, 19, 4):
                a = (a - c) & _M ^ _rot(c, k)
                c = (c + b) & _M
                a, b, c = b, c, a
        else:
            # final: x ^= y; x -= rot(y, k), (x, y) turning (c, b) -> (a, c) -> (b, a)
            for k in (14, 11, 25, 16, 4, 14, 24):
                c = (c ^ b) - _rot(b, k) & _M
                a, b, c = b, c, a
            a, b, c = c, a, b          # seven turns of three roles: one back
    return c
