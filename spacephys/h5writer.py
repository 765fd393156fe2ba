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
    """Reset the consistency flags a killed writer left (and the superblock's checksum).
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
    word = lambda i: int.from_bytes(data[i:i + 4], "little")
    i = 0
    while n > 12:
        a, b, c = (a + word(i)) & _M, (b + word(i + 4)) & _M, (c + word(i + 8)) & _M
        # mix
        a = (a - c) & _M ^ _rot(c, 4)
        c = (c + b) & _M
        b = (b - a) & _M ^ _rot(a, 6)
        a = (a + c) & _M
        c = (c - b) & _M ^ _rot(b, 8)
        b = (b + a) & _M
        a = (a - c) & _M ^ _rot(c, 16)
        c = (c + b) & _M
        b = (b - a) & _M ^ _rot(a, 19)
        a = (a + c) & _M
        c = (c - b) & _M ^ _rot(b, 4)
        b = (b + a) & _M
        n -= 12
        i += 12
    if n == 0:
        return c
    tail = data[i:i + n] + bytes(12 - n)
    a = (a + int.from_bytes(tail[0:4], "little")) & _M
    b = (b + int.from_bytes(tail[4:8], "little")) & _M
    c = (c + int.from_bytes(tail[8:12], "little")) & _M
    # final
    c = (c ^ b) - _rot(b, 14) & _M
    a = (a ^ c) - _rot(c, 11) & _M
    b = (b ^ a) - _rot(a, 25) & _M
    c = (c ^ b) - _rot(b, 16) & _M
    a = (a ^ c) - _rot(c, 4) & _M
    b = (b ^ a) - _rot(a, 14) & _M
    c = (c ^ b) - _rot(b, 24) & _M
    return c
