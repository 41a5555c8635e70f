"""The near field on a tensor grid when a fine cell holds a sample or two a side: vectorised over segments (compiled).

``grid.near_field_grid``'s column visits run their inner loop over a window
of three cells' samples: at one sample a cell (level 10 at 1024^2) that is
three iterations, too few for a vector loop, and each visit pays its set-up
for a handful of pairs.  Here a thread takes a row of cells and the segments
of the three rows of cells around it (one contiguous run, segments being
sorted by cell); every segment sees the samples of the three cells around its
own column in that row.  For each offset ``j`` into those windows, one loop
over the run's segments computes the layers at each segment's ``j``-th sample
(vectorised, the samples' coordinates gathered) and a second adds them to the
row's samples (scattered; a few multiply-adds a pair).  Segments share no
logarithms here (two a pair, against one on a chain in ``grid``'s loop), which
the long vector loop more than pays for: measured at 1024^2 on the Hilbert
benchmark, 524,288 pieces at level 10, 394 -> 158 ms, and equal at 2 x 2
samples a cell (32,768 pieces, level 9); with more samples a cell the
column visits are faster.
"""

from __future__ import annotations

import numba
import numpy as np

from .fastmath import POLY_MATH
from .rows import spread_rows
from .segment_sums import segment_potentials


def _row_of(channels):
    """``row_of`` of ``channels`` (3 or 4), a compiled kernel each (as ``grid._near_grid_of``)."""

    @numba.njit(cache=True, fastmath=POLY_MATH, error_model="numpy")
    def row_of(cy, xs, ys, x_start, y_start, n, cell_start, table, weights, column, out):
        """Add the near field of the samples of cell row ``cy`` to ``out``."""
        nx = xs.shape[0]
        ya, rows = y_start[cy], y_start[cy + 1] - y_start[cy]
        k0, k1 = cell_start[max(cy - 1, 0) * n], cell_start[min(cy + 2, n) * n]
        m = k1 - k0
        single, double, x = np.empty(m), np.empty(m), np.empty(m)
        first, stop = np.empty(m, np.int64), np.empty(m, np.int64)
        acc = np.zeros((channels, rows, nx))
        width = 0
        for i in range(m):
            cx = column[k0 + i]
            first[i], stop[i] = x_start[max(cx - 1, 0)], x_start[min(cx + 2, n)]
            width = max(width, stop[i] - first[i])
        px, py, qx, qy = table[0, k0:k1], table[1, k0:k1], table[2, k0:k1], table[3, k0:k1]
        tx, ty, h = table[4, k0:k1], table[5, k0:k1], table[6, k0:k1]
        for a in range(rows):
            y = ys[ya + a]
            for j in range(width):
                for i in range(m):
                    x[i] = xs[min(first[i] + j, nx - 1)]  # past a window's end: computed, not added
                for i in range(m):
                    single[i], double[i] = segment_potentials(x[i], y, px[i], py[i], qx[i], qy[i], tx[i], ty[i], h[i])
                for i in range(m):
                    b = first[i] + j
                    if b < stop[i]:
                        k, s, d = k0 + i, single[i], double[i]
                        for c in range(channels):
                            acc[c, a, b] += weights[c, k] * s - weights[channels + c, k] * d
        for a in range(rows):
            for b in range(nx):
                for c in range(channels):
                    out[ya + a, b, c] += acc[c, a, b]

    return row_of


_row3, _row4 = _row_of(3), _row_of(4)


def _near_rows_of(channels):
    """``near_rows_of`` of ``channels``: threads take rows of cells (``rows.spread_rows``); each writes its own
    samples."""
    four = channels == 4

    @numba.njit(parallel=True, cache=True, error_model="numpy")
    def near_rows_of(xs, ys, x_start, y_start, n, cell_start, table, weights, column, out):
        spread = spread_rows(y_start)
        for t in numba.prange(len(spread)):
            cy = spread[t]
            if y_start[cy] < y_start[cy + 1] and cell_start[max(cy - 1, 0) * n] < cell_start[min(cy + 2, n) * n]:
                if four:
                    _row4(cy, xs, ys, x_start, y_start, n, cell_start, table, weights, column, out)
                else:
                    _row3(cy, xs, ys, x_start, y_start, n, cell_start, table, weights, column, out)

    return near_rows_of


#: The kernel of each count of channels.
_NEAR_ROWS = {channels: _near_rows_of(channels) for channels in (3, 4)}


def near_rows(xs: np.ndarray, ys: np.ndarray, x_start: np.ndarray, y_start: np.ndarray, n: int,
              cell_start: np.ndarray, table: np.ndarray, weights: np.ndarray, out: np.ndarray) -> None:
    """Add the near field of segments sorted by cell to ``out`` on the grid ``ys x xs`` (``grid.near_field_grid``'s
    arguments, checked, with the cells' runs of samples ``x_start, y_start``)."""
    column = (np.repeat(np.arange(n * n, dtype=np.int64), np.diff(cell_start)) % n).astype(np.int64)
    _NEAR_ROWS[out.shape[2]](xs, ys, x_start, y_start, n, cell_start, table, weights, column, out)
