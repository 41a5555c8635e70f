"""Entries of the collocation matrix on demand, for the solvers that need blocks of it.

Row i is the field of unit densities at segment midpoint i: column j is
``S_ij`` on a curve segment and ``-D_ij`` on a border segment, with the
principal value (``D_ii = 0``) and the border's ``-1/2`` on the diagonal
(``dense``, DESIGN section 3).  The skeleton factorisation asks for the
blocks it compresses, the updated solve for the rows and columns of the
segments an edit replaced.
"""

from __future__ import annotations

import numba
import numpy as np

from ..geometry.segments import Segments
from ..kernels.fastmath import POLY_MATH
from ..kernels.segment_sums import segment_potentials, segment_table


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def _entries_row(x, y, own, columns, table, border, row):
    for b in range(table.shape[1]):  # contiguous rows, branch-free: vectorises
        s, d = segment_potentials(x, y, table[0, b], table[1, b], table[2, b], table[3, b], table[4, b], table[5, b], table[6, b])
        d = 0.0 if columns[b] == own else d  # principal value on the segment itself
        row[b] = -d if border[b] else s
    if own >= 0:
        for b in range(table.shape[1]):
            if columns[b] == own and border[b]:
                row[b] -= 0.5


# Small blocks run serially: waking threads costs more than they save, and
# stalls behind BLAS's spinning threads on a busy machine.  The serial kernel
# releases the GIL, so threads compressing different boxes run it side by side.
# (Two functions, not one compiled twice: numba's cache would confuse the two.)
@numba.njit(cache=True, nogil=True, fastmath=POLY_MATH, error_model="numpy")
def _entries_serial(targets, target_ids, columns, table, border, out):
    for a in range(targets.shape[0]):
        _entries_row(targets[a, 0], targets[a, 1], target_ids[a], columns, table, border, out[a])


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _entries_parallel(targets, target_ids, columns, table, border, out):
    for a in numba.prange(targets.shape[0]):
        _entries_row(targets[a, 0], targets[a, 1], target_ids[a], columns, table, border, out[a])


#: Pairs from which a block is computed in parallel.
PARALLEL_PAIRS = 200_000


class CollocationEntries:
    """Entries of the collocation matrix of ``segments`` on demand.

    Row i evaluates the field of unit densities at midpoint i: column j is
    ``S_ij`` on a curve segment, ``-D_ij`` on a border segment, with the
    principal value and the border's ``-1/2`` on the diagonal (``dense``).
    """

    def __init__(self, segments: Segments) -> None:
        self.table = segment_table(segments.p, segments.q)
        self.border = np.asarray(segments.on_border, np.bool_)
        self.midpoints = segments.midpoints
        self.length = self.table[6]

    def flux_scale(self) -> np.ndarray:
        """Per unknown: ``1 / h`` on a curve segment, 1 on the border.

        A curve segment's column is about ``h`` times the log kernel, so its
        entries scale with its length; times this scale, every column is of
        order one (the unknown becomes the segment's total flux ``E h``).
        The border's columns hold the ``-1/2`` of the diagonal whatever ``h``.
        """
        return np.where(self.border, 1.0, 1.0 / np.maximum(self.length, np.finfo(float).tiny))

    def block(self, rows: np.ndarray, columns: np.ndarray, parallel: bool = True) -> np.ndarray:
        """``A[rows][:, columns]``, ``(len(rows), len(columns))``; see ``at`` for ``parallel``."""
        return self.at(self.midpoints[rows], columns, rows, parallel)

    def at(
        self, points: np.ndarray, columns: np.ndarray, ids: np.ndarray | None = None, parallel: bool = True
    ) -> np.ndarray:
        """Field of unit densities on ``columns`` at ``points`` (not on those segments unless ``ids`` says so).

        Large blocks are computed on numba's threads unless ``parallel`` is
        false (for callers that run on threads of their own).
        """
        out = np.empty((len(points), len(columns)))
        ids = np.full(len(points), -1, np.int64) if ids is None else ids
        kernel = _entries_parallel if parallel and out.size >= PARALLEL_PAIRS else _entries_serial
        table = np.ascontiguousarray(self.table[:, columns])  # fancy indexing may not give C order
        kernel(np.ascontiguousarray(points), ids, columns, table, self.border[columns], out)
        return out
