"""Rows of cells spread over the threads.

numba's ``prange`` hands each thread one contiguous range of its iterations
(under the omp and workqueue threading layers, whatever
``numba.parallel_chunksize`` asks), so a kernel over a lattice's rows of
cells gave one thread all the rows of a band of the picture, and the thread
with the busier part of a picture set the pace.  A kernel walks
``spread_rows`` instead: the rows in the van der Corput order (the bits of
their index reversed), whose every contiguous part is spread evenly over
all of them.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def spread_rows(start):
    """``(count,)`` int64: the rows ``first .. first + count - 1`` from the first to the last that hold samples, of
    the runs ``start (n + 1,)`` of samples of ``n`` rows (``grid.grid_cell_runs``), in the order of their offsets
    from ``first`` with their bits reversed (``0, 4, 2, 6, 1, 5, 3, 7`` of 8): the half of them a thread takes holds
    every other row, its quarter every fourth (nearly so when their count is not a power of two)."""
    n = len(start) - 1
    first, last = 0, n
    while first < n and start[first] == start[first + 1]:
        first += 1
    while last > first and start[last - 1] == start[last]:
        last -= 1
    count = max(last - first, 0)
    bits = 0
    while (1 << bits) < count:
        bits += 1
    order = np.empty(count, np.int64)
    k = 0
    for t in range(1 << bits):
        offset = 0
        for b in range(bits):
            offset |= ((t >> b) & 1) << (bits - 1 - b)
        if offset < count:
            order[k] = first + offset
            k += 1
    return order
