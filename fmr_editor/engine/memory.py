"""How much memory this process may still take: what builds and readers check their estimates against; the
allocator set to give freed arrays back (``return_freed_arrays``, ``give_back_spare_pages``); and the modules'
objects kept out of the garbage collector's full passes (``freeze_loaded_objects``)."""

from __future__ import annotations

import ctypes
import gc
import os
import resource
import sys
import threading
from functools import lru_cache

from ..model.limits import LimitError


def available_memory() -> int:
    """Bytes this process may still allocate, as far as can be told.

    The least of the system's ``MemAvailable`` (else its physical memory),
    what the address-space limit (``RLIMIT_AS``, as a worker under a memory
    cap has) leaves above what is mapped now, and what the control group's
    ``memory.max`` leaves above its ``memory.current``.
    """
    limits = [_meminfo("MemAvailable") or os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")]
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        limits.append(max(soft - _status("VmSize"), 0))
    group = _read_number("/sys/fs/cgroup/memory.max")
    if group is not None:
        limits.append(max(group - (_read_number("/sys/fs/cgroup/memory.current") or 0), 0))
    return min(limits)


def _meminfo(key: str) -> int | None:
    return _field("/proc/meminfo", key)


def _status(key: str) -> int:
    return _field("/proc/self/status", key) or 0


def _field(path: str, key: str) -> int | None:
    """A ``key: N kB`` line of a ``/proc`` file, in bytes."""
    try:
        with open(path) as lines:
            for line in lines:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _read_number(path: str) -> int | None:
    """A file holding one number (``max`` and absent files: None)."""
    try:
        with open(path) as file:
            text = file.read().strip()
        return int(text) if text.isdigit() else None
    except (OSError, ValueError):
        return None


#: Bytes a build holds at its peak per boundary unknown (the solve's factorisation and products): roses,
#: 90,000 unknowns, peaks at 1.1 GB.
BYTES_PER_UNKNOWN = 12_000
#: Bytes a build holds at its peak per fine cell and expansion term: the local and the fine multipole
#: expansions (3 channels of complex terms), the coarser levels' and the passes' temporaries.
BYTES_PER_CELL_TERM = 4 * 3 * 16
#: Share of the available memory a build plans to use (the rest: the document, the image, the interface).
BUILD_SHARE = 0.75


def affordable_levels(levels: int, terms: int, available: int | None = None) -> int:
    """``levels``, or fewer when a lattice that deep, of ``terms`` expansion terms a cell
    (``Settings.propagation_order + 1``), would not fit in memory (at least 2).

    A coarser lattice only puts more segments in each cell (pixels cost
    more), so a huge canvas is built on the lattice the memory allows.
    """
    budget = BUILD_SHARE * (available_memory() if available is None else available)
    while levels > 2 and 4**levels * terms * BYTES_PER_CELL_TERM > budget:
        levels -= 1
    return levels


def check_build_memory(unknowns: int, levels: int = 0, terms: int = 0, available: int | None = None) -> None:
    """Refuse a build of ``unknowns`` boundary segments on a lattice of ``levels`` with ``terms`` expansion terms
    a cell that would not fit in memory (the default 0 and 0: the segments alone, before a lattice is chosen).

    Raises
    ------
    LimitError
        Naming the estimate and the memory available.
    """
    available = available_memory() if available is None else available
    need = unknowns * BYTES_PER_UNKNOWN + (4**levels * terms * BYTES_PER_CELL_TERM if levels else 0)
    if need > BUILD_SHARE * available:
        raise LimitError(f"building this document needs about {_gigabytes(need)} of memory "
                         f"({unknowns:,} boundary segments), more than the {_gigabytes(available)} available")


#: Bytes a render holds at its peak per output pixel: the image of 3 float64 channels and the far and near
#: fields summed into it.
BYTES_PER_PIXEL = 4 * 3 * 8


def check_image_memory(width: int, height: int, available: int | None = None) -> None:
    """Refuse to render a ``width x height`` image that would not fit in memory.

    Raises
    ------
    LimitError
        Naming the size, the estimate and the memory available.
    """
    available = available_memory() if available is None else available
    need = width * height * BYTES_PER_PIXEL
    if need > BUILD_SHARE * available:
        raise LimitError(f"rendering {width:,} x {height:,} pixels needs about {_gigabytes(need)} of memory, "
                         f"more than the {_gigabytes(available)} available")


def _gigabytes(count: int) -> str:
    return f"{count / 2**30:.1f} GB"


#: Arrays of at least this many bytes get pages of their own from glibc's ``malloc`` (``mmap``), which go back
#: to the system as soon as the array is freed.  Smaller ones, a level-7 lattice's expansions among them (128^2
#: cells, 3 channels, 17 terms: 13 MB), come from the heap, where a freed block is used again without new
#: page faults.
OWN_PAGES = 16 * 2**20
#: Bytes by which the resident memory may grow before the heap's free pages go back (``give_back_spare_pages``).
SPARE_HEAP = 64 * 2**20
#: ``mallopt``'s parameter numbers (glibc's ``malloc.h``).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def return_freed_arrays(threshold: int = OWN_PAGES, spare: int = SPARE_HEAP) -> bool:
    """Set glibc's ``malloc`` for the process: blocks of ``threshold`` bytes or more get pages of their own, and
    the heap keeps up to ``spare`` free bytes at its top instead of returning them at every ``free``.

    glibc's own rule raises the first threshold after each such block is
    freed, up to 32 MB: after the first few-megabyte array is freed, arrays
    smaller than it come from the heap, and the engine's arrays of a few
    megabytes, kept as long as the undo cache keeps their state
    (``kept_states``) and freed in another order than they were made, filled
    it with holes that stayed resident: on lady_bug's soak
    (``bench/soak.py``) resident memory grew by 629 MB after the first 1,000
    steps while what was allocated stayed flat.  A fixed threshold stops the
    raising; the holes below it go back with ``give_back_spare_pages``,
    which the engine calls after every job.

    The threshold is not lower because a fresh page costs a page fault, and
    on a virtual machine that gives free pages back to its host (this
    project's: "free page reporting") one costs 2-3 ms a MB: with 256 KB,
    the arrays of a paste of 20,000 segments faulted 23,000 pages (about
    50 ms of 190), lady_bug's anchor move took 88-93 ms against 67 with
    4 MB, and P2M of 2,048 curves at level 7 5.9-6.6 ms with 4 MB against
    1.7-1.8 with 16 MB (roses' edits alike with either).

    Does nothing, and returns False, where there is no glibc (other systems'
    allocators return large blocks themselves) or when the environment sets
    ``MALLOC_MMAP_THRESHOLD_`` (the user's choice stands).

    Returns
    -------
    bool
        True when the thresholds were set.
    """
    mallopt = _libc_function("mallopt", ctypes.c_int, ctypes.c_int)
    if mallopt is None or "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, int(threshold))) and bool(mallopt(_M_TRIM_THRESHOLD, int(spare)))


@lru_cache(maxsize=None)
def _libc_function(name: str, *argtypes, restype=ctypes.c_int):
    """The C library's function ``name`` on Linux, or None where there is none."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        function = getattr(ctypes.CDLL(None), name)
    except (OSError, AttributeError):
        return None
    function.argtypes, function.restype = list(argtypes), restype
    return function


def give_back_free_pages() -> bool:
    """Give the whole free pages inside glibc's heaps back to the system (``malloc_trim``).

    Blocks below ``OWN_PAGES`` come from the heaps, and glibc returns only
    the free space at a heap's top by itself: a freed block between live
    ones stays resident (on lady_bug's soak the heap's free space grew from
    22 to 126 MB over 6,500 steps).  0.6 ms in a fresh process.  Returns
    False where there is no glibc.
    """
    trim = _libc_function("malloc_trim", ctypes.c_size_t)
    if trim is None:
        return False
    trim(0)
    return True


class _SpareHeap:
    """What ``give_back_spare_pages`` measures from since the heap's free pages last went back (one per process, as
    the heap is): the lowest resident memory and the most bytes in use in the heap (0 before they ever went back)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.lowest = 0
        self.most_in_use = 0


@lru_cache(maxsize=1)
def _spare_heap() -> _SpareHeap:
    return _SpareHeap()


def give_back_spare_pages(spare: int = SPARE_HEAP) -> bool:
    """Give the heap's free pages back once ``spare`` bytes of them may be resident; True when they went back.

    That is when, since they last went back, the resident memory grew
    ``spare`` above its lowest (blocks freed and not used again, between
    live ones), or the bytes in use in the heap fell ``spare`` below their
    most (arrays freed: the states the undo cache lets go), both as seen at
    the calls.  Called after each of the engine's jobs (``LiveStack``):
    within a job and from one job to the next (the frames of a drag) freed
    blocks are used again without page faults, while resident memory stays
    within about ``spare`` of what is held.
    """
    held = _spare_heap()
    with held.lock:
        now, in_use = resident_bytes(), heap_in_use()
        held.lowest, held.most_in_use = min(held.lowest, now), max(held.most_in_use, in_use)
        if now - held.lowest <= spare and held.most_in_use - in_use <= spare:
            return False
        given = give_back_free_pages()
        held.lowest, held.most_in_use = resident_bytes(), heap_in_use()
        return given


class _MallocInfo(ctypes.Structure):
    """glibc's ``struct mallinfo2``."""

    _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                     "fsmblks", "uordblks", "fordblks", "keepcost")]


def heap_in_use() -> int:
    """Bytes of glibc's heaps in use (``mallinfo2``'s ``uordblks``, every arena; 0 where there is no glibc 2.33)."""
    info = _libc_function("mallinfo2", restype=_MallocInfo)
    return int(info().uordblks) if info is not None else 0


def resident_bytes() -> int:
    """This process's resident memory (``VmRSS``; 0 where there is no ``/proc``)."""
    return _status("VmRSS")


@lru_cache(maxsize=1)
def freeze_loaded_objects() -> int:
    """Move the objects tracked so far out of the cyclic garbage collector's passes (``gc.freeze``), once per
    process; the number frozen.

    ``setup_process`` calls it before any document exists, when what is alive is the imported modules'
    objects, which live as long as the process (so none of them is ever garbage the collector would miss).  Its
    full passes traverse every tracked object and come every few builds or many edits: on repeated lady_bug
    builds a pass every 7 builds took 99-150 ms over 138,000 objects, a hitch in a drag; with the 75,000 of the
    modules frozen, 45-74 ms.  Objects made later, documents among them, are never frozen.
    """
    gc.freeze()
    return gc.get_freeze_count()
