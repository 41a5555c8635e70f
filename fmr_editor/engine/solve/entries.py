"""Entries of the collocation matrix on demand, for the solvers that need blocks of it.

Row i is the field of unit densities at segment midpoint i: column j is
``S_ij`` on a curve segment and ``-D_ij`` on a border segment, with the
principal value (``D_ii = 0``) and the border's ``-1/2`` on the diagonal
(``dense``, docs/design.md section 2).  The skeleton factorisation asks for the
blocks it compresses, the updated solve for the rows and columns of the
segments an edit replaced.

Most entries of those blocks couple segments many lengths apart: there the
single layer comes from its series (``_single_far``: one logarithm, within
1e-14 of the closed form), the closed form only near each segment and on
the border (measured on roses: 46 against 33 M entries per second).
"""

from __future__ import annotations

import numba
import numpy as np

from ..geometry.segments import Segments
from ..kernels.fastmath import INV_TWO_PI, POLY_MATH, log_poly
from ..kernels.segment_sums import segment_potentials, segment_table

#: Distance from a segment's midpoint, in segment lengths, beyond which its single layer comes from
#: ``_single_far`` (truncation below 1e-14 of ``h / 2 pi`` there).
FAR = 8.0


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def _single_far(x, y, cx, cy, tx, ty, h):
    """The single layer at (x, y) of a segment (midpoint c) beyond ``FAR`` lengths: its series in ``h / 2r``.

    With w = x - c (complex) and z = (h / 2) t / w,
    ``S = h / 2 pi [log |w| - sum over even k of Re z^k / (k (k + 1))]``;
    the terms up to k = 8 leave under ``|z|^10 / 110`` (``|z| <= 1 / 16``).
    One logarithm and no arctangent, against two and one for the closed form.
    """
    wx, wy = x - cx, y - cy
    r2 = wx * wx + wy * wy
    f = 0.5 * h / r2
    zx, zy = f * (tx * wx + ty * wy), f * (ty * wx - tx * wy)  # (h / 2) t conj(w) / |w|^2
    z2x, z2y = zx * zx - zy * zy, 2.0 * zx * zy
    z4x, z4y = z2x * z2x - z2y * z2y, 2.0 * z2x * z2y
    z6x = z4x * z2x - z4y * z2y
    z8x = z4x * z4x - z4y * z4y
    series = z2x / 6.0 + z4x / 20.0 + z6x / 42.0 + z8x / 72.0
    return h * (0.5 * log_poly(r2) - series) * INV_TWO_PI


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def _entries_row(x, y, own, columns, table, border, row, exact):
    """Row of entries at (x, y) (``own``: the row's segment, or -1); ``exact`` is scratch of the row's length."""
    n = table.shape[1]
    for b in range(n):  # contiguous rows, branch-free: vectorises
        row[b] = _single_far(x, y, table[7, b], table[8, b], table[4, b], table[5, b], table[6, b])
    count = 0
    for b in range(n):  # near (or on the border: reach +inf)
        wx, wy = x - table[7, b], y - table[8, b]
        if wx * wx + wy * wy <= table[9, b]:
            exact[count] = b
            count += 1
    for i in range(count):  # the closed form where the series does not hold
        b = exact[i]
        s, d = segment_potentials(x, y, table[0, b], table[1, b], table[2, b], table[3, b], table[4, b], table[5, b],
                                  table[6, b])
        d = 0.0 if columns[b] == own else d  # principal value on the segment itself
        row[b] = -d if border[b] else s
        if columns[b] == own and border[b]:
            row[b] -= 0.5


# Small blocks run serially: waking threads costs more than they save, and
# stalls behind BLAS's spinning threads on a busy machine.  The serial kernel
# releases the GIL, so threads compressing different boxes run it side by side.
# (Two functions, not one compiled twice: numba's cache would confuse the two.)
@numba.njit(cache=True, nogil=True, fastmath=POLY_MATH, error_model="numpy")
def _entries_serial(targets, target_ids, columns, table, border, out):
    exact = np.empty(table.shape[1], np.int64)
    for a in range(targets.shape[0]):
        _entries_row(targets[a, 0], targets[a, 1], target_ids[a], columns, table, border, out[a], exact)


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _entries_parallel(targets, target_ids, columns, table, border, out):
    for a in numba.prange(targets.shape[0]):
        _entries_row(targets[a, 0], targets[a, 1], target_ids[a], columns, table, border, out[a],
                     np.empty(table.shape[1], np.int64))


#: Pairs from which a block is computed in parallel.
PARALLEL_PAIRS = 200_000


class CollocationEntries:
    """Entries of the collocation matrix of ``segments`` on demand.

    Row i evaluates the field of unit densities at midpoint i: column j is
    ``S_ij`` on a curve segment, ``-D_ij`` on a border segment, with the
    principal value and the border's ``-1/2`` on the diagonal (``dense``).
    """

    def __init__(self, segments: Segments) -> None:
        table = segment_table(segments.p, segments.q)
        # rows 7-9: midpoint and the squared distance within which the closed form is used
        reach = np.where(segments.on_border, np.inf, (FAR * table[6]) ** 2)
        self.table = np.vstack([table, segments.midpoints.T, reach])
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
