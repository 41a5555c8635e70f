"""The near part of the collocation matrix, kept for the products of one iterative solve.

Every FMM product of the solve sums the segments in the 3x3 cells around each
midpoint exactly (``segment_sums.near_sum``): a logarithm and an arctangent a
pair, the bulk of a product (lady_bug: 16 of 25 ms).  Within one GMRES solve
those pairs and their entries never change, so ``NearMatrix`` computes them
once, in about the time of one product's near field, and each later product
is a multiply-add a pair.

Segments are sorted by the fine cell of their midpoint, so the targets of
cell c are the segments ``cell_start[c]:cell_start[c + 1]`` and their
sources three contiguous runs (the rows of the 3x3 block): each target's
entries are stored as one row, one target after another, with no indices.
"""

from __future__ import annotations

import numba
import numpy as np

from ..geometry.segments import Segments
from ..kernels.fastmath import POLY_MATH
from ..kernels.segment_sums import segment_potentials, segment_table

#: Most bytes the entries may take; a larger system sums its near field afresh in each product.
NEAR_MATRIX_BYTES = 256 * 2**20


@numba.njit(cache=True, inline="always")
def _runs(c, n):
    """The 3x3 cells around cell ``c``: their first and last lattice rows and columns (the last excluded)."""
    cy, cx = c // n, c % n
    return max(cy - 1, 0), min(cy + 2, n), max(cx - 1, 0), min(cx + 2, n)


@numba.njit(cache=True)
def _row_starts(n, cell_start):
    """Where each target's row of entries starts, ``(targets + 1,)``."""
    start = np.zeros(cell_start[-1] + 1, np.int64)
    for c in range(n * n):
        row0, row1, col0, col1 = _runs(c, n)
        sources = 0
        for row in range(row0, row1):
            sources += cell_start[row * n + col1] - cell_start[row * n + col0]
        for i in range(cell_start[c], cell_start[c + 1]):
            start[i + 1] = start[i] + sources
    return start


@numba.njit(cache=True)
def _cells(n, cell_start):
    """Each target's cell."""
    cell = np.empty(cell_start[-1], np.int64)
    for c in range(n * n):
        cell[cell_start[c]:cell_start[c + 1]] = c
    return cell


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _entries(n, cell_start, row_start, cell, midpoints, table, border, out, curve_double):
    """``out``: the collocation entries; ``curve_double`` (unless empty): ``D_ij`` of curve segments, 0 on the
    border's."""
    doubles = len(curve_double) > 0
    for i in numba.prange(len(cell)):
        x, y = midpoints[i, 0], midpoints[i, 1]
        row0, row1, col0, col1 = _runs(cell[i], n)
        k = row_start[i]
        for row in range(row0, row1):
            first, last = cell_start[row * n + col0], cell_start[row * n + col1]
            entries, double = out[k:k + last - first], curve_double[k:k + last - first] if doubles else out[:0]
            for j in range(first, last):  # branch-free but for the loop's own ``doubles``: it vectorises
                s, d = segment_potentials(x, y, table[0, j], table[1, j], table[2, j], table[3, j],
                                          table[4, j], table[5, j], table[6, j])
                entries[j - first] = s - border[j] * (s + d)
                if doubles:
                    double[j - first] = d - border[j] * d
            if first <= i < last:  # the principal value on its own midpoint
                if border[i]:
                    entries[i - first] = 0.0
                if doubles:
                    double[i - first] = 0.0
            k += last - first


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _product(n, cell_start, row_start, cell, entries, x, out):
    for i in numba.prange(len(cell)):
        row0, row1, col0, col1 = _runs(cell[i], n)
        k = row_start[i]
        r = g = b = 0.0
        for row in range(row0, row1):
            first, last = cell_start[row * n + col0], cell_start[row * n + col1]
            for j in range(first, last):
                a = entries[k + j - first]
                r += a * x[j, 0]
                g += a * x[j, 1]
                b += a * x[j, 2]
            k += last - first
        out[i, 0], out[i, 1], out[i, 2] = r, g, b


class NearMatrix:
    """The 3x3-cell part of the collocation matrix of sorted segments, as ``CollocationOperator.apply`` sums it.

    Entry (i, j) is ``S_ij`` for a curve segment j and ``-D_ij`` for a border
    segment (0 on its own midpoint: the principal value; the border's
    ``-1/2`` is the operator's), for every j in the 3x3 cells around
    midpoint i's cell.

    With ``curve_double``, it also keeps the curve segments' double layer ``D_ij`` over the same pairs (0 on
    the border's and on a segment's own midpoint), the right-hand side's near part (``double_layer``).

    Parameters
    ----------
    segments : Segments
        Sorted by the fine cell of their midpoints.
    cell_start : numpy.ndarray
        CSR offsets of each cell's segments, ``(cells_per_side**2 + 1,)``.
    cells_per_side : int
    curve_double : bool
    """

    def __init__(self, segments: Segments, cell_start: np.ndarray, cells_per_side: int,
                 curve_double: bool = False, row_start: np.ndarray | None = None) -> None:
        self.n, self.cell_start = int(cells_per_side), np.asarray(cell_start, np.int64)
        self.row_start = _row_starts(self.n, self.cell_start) if row_start is None else row_start
        self.cell = _cells(self.n, self.cell_start)
        self.entries = np.empty(self.row_start[-1])
        self.curve_double = np.empty(self.row_start[-1] if curve_double else 0)
        _entries(self.n, self.cell_start, self.row_start, self.cell,
                 np.ascontiguousarray(segments.midpoints, np.float64), segment_table(segments.p, segments.q),
                 np.asarray(segments.on_border, np.float64), self.entries, self.curve_double)

    @classmethod
    def within_budget(cls, segments: Segments, cell_start: np.ndarray, cells_per_side: int,
                      curve_double: bool = False) -> NearMatrix | None:
        """The near matrix, or None where its entries would exceed ``NEAR_MATRIX_BYTES``."""
        row_start = _row_starts(int(cells_per_side), np.asarray(cell_start, np.int64))
        if 8 * (2 if curve_double else 1) * row_start[-1] > NEAR_MATRIX_BYTES:
            return None
        return cls(segments, cell_start, cells_per_side, curve_double, row_start)

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        """The near part of the product with ``x`` of shape ``(n, 3)`` (sorted like the segments)."""
        return self._times(self.entries, x)

    def double_layer(self, jump: np.ndarray) -> np.ndarray:
        """The near part of ``sum_j D_ij jump_j`` over the curve segments, ``jump`` of shape ``(n, 3)``."""
        if not len(self.curve_double):
            raise ValueError("this near matrix keeps no double layer")
        return self._times(self.curve_double, jump)

    def _times(self, entries: np.ndarray, x: np.ndarray) -> np.ndarray:
        out = np.empty((len(x), 3))
        _product(self.n, self.cell_start, self.row_start, self.cell, entries, np.ascontiguousarray(x, np.float64),
                 out)
        return out
