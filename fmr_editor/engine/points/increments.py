"""Adding and removing diffusion points on a fine-cell tensor (compiled).

A polynomial point's delta is, in each fine cell below its grid cells,
``w (x) X (x) Y`` with ``X = S[b] ux`` (``gauss.shift_matrices``) depending only
on the fine column and ``Y = S[a] uy`` only on the fine row: the same
polynomial ``tensor.point_polynomials`` builds (up to rounding), computed
per point.  Removing points is adding ``points.negated()``: the delta is then
the same products with the sign flipped, so add-then-remove restores the
tensor up to the rounding of the two additions.

Near points are not in the tensor; the caller rebuilds its
``near.NearPoints`` (cheap: sorting the near points' cell lists).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..fmm.lattice import Lattice
from ..kernels.fastmath import FAST_MATH
from .gauss import GaussPoints, PointSettings, changed_cells, cutoff_radii, expansion_ratios
from .tensor_kernels import hermite_column


@numba.njit(cache=True, fastmath=FAST_MATH)
def _fine_factors(coord, r, reach, ratio, cell_size, n, binom, inv, out, start):
    """Fill ``out[start:]`` with ``S[b] u`` for each fine cell along one axis; returns (first fine cell, count).

    ``u`` is the point's scaled Hermite vector on the grid cell (``ratio`` fine
    cells wide) above the fine cell, ``b`` the fine cell's place in it.
    """
    width = inv.shape[0]
    size = ratio * cell_size
    cells = (n + ratio - 1) // ratio
    first = max(int(math.floor((coord - reach) / size)), 0)
    last = min(int(math.ceil((coord + reach) / size)) - 1, cells - 1)
    if first > last:
        return 0, 0
    fine0, fine1 = first * ratio, min((last + 1) * ratio, n)
    u = np.empty((width, 1))
    for f in range(fine0, fine1):
        cell, b = f // ratio, f % ratio
        if f == fine0 or b == 0:
            hermite_column((coord - (cell + 0.5) * size) / r, size / r, inv, u, 0)
        d = (b + 0.5) / ratio - 0.5
        scale = 1.0
        for q in range(width):
            total, power = 0.0, 1.0
            for i in range(q, width):
                total += u[i, 0] * binom[i, q] * power
                power *= d
            out[start + f - fine0, q] = total * scale
            scale /= ratio
    return fine0, fine1 - fine0


@numba.njit(cache=True, fastmath=FAST_MATH)
def _add_products(out, w, xf, x_first, x_start, yf, y_first, y_start):
    """``out[row, col] += sum_k (w_k (x) xf_k[col]) (x) yf_k[row]`` over the points' fine windows.

    ``out`` is viewed as ``(n, n, 3 (P+1), P+1)``.  Each cell's sum over the
    points is formed in a small buffer and added once, so a cell is read and
    written once however many of a dab's points cover it.  Serial: a dab
    takes milliseconds, and on a shared machine a parallel region measured
    here could wait several for its second thread.
    """
    width = out.shape[-1]
    rows = 3 * width
    count = w.shape[0]
    coef = np.empty((x_start[count], rows))
    row_a, row_b, col_a, col_b = out.shape[0], -1, out.shape[1], -1
    for k in range(count):
        for b in range(x_start[k + 1] - x_start[k]):
            for c in range(3):
                for i in range(width):
                    coef[x_start[k] + b, c * width + i] = w[k, c] * xf[x_start[k] + b, i]
        if x_start[k + 1] > x_start[k] and y_start[k + 1] > y_start[k]:
            row_a, row_b = min(row_a, y_first[k]), max(row_b, y_first[k] + y_start[k + 1] - y_start[k])
            col_a, col_b = min(col_a, x_first[k]), max(col_b, x_first[k] + x_start[k + 1] - x_start[k])
    acc = np.empty((rows, width))
    for row in range(row_a, row_b):
        for col in range(col_a, col_b):
            touched = False
            for k in range(count):
                a, b = row - y_first[k], col - x_first[k]
                if a < 0 or b < 0 or a >= y_start[k + 1] - y_start[k] or b >= x_start[k + 1] - x_start[k]:
                    continue
                if not touched:
                    acc[:] = 0.0
                    touched = True
                yv, cv = yf[y_start[k] + a], coef[x_start[k] + b]
                for ci in range(rows):
                    for j in range(width):
                        acc[ci, j] += cv[ci] * yv[j]
            if touched:
                cell = out[row, col]
                for ci in range(rows):
                    for j in range(width):
                        cell[ci, j] += acc[ci, j]


@numba.njit(cache=True)
def _all_factors(x, y, r, reach, ratio, cell_size, n, binom, inv):
    k, width = x.shape[0], inv.shape[0]
    x_first, y_first = np.zeros(k, np.int64), np.zeros(k, np.int64)
    x_start, y_start = np.zeros(k + 1, np.int64), np.zeros(k + 1, np.int64)
    for p in range(k):
        span = (2 * int(math.ceil(reach[p] / (ratio[p] * cell_size))) + 2) * ratio[p]
        x_start[p + 1] = x_start[p] + min(span, n)
        y_start[p + 1] = y_start[p] + min(span, n)
    xf, yf = np.empty((x_start[k], width)), np.empty((y_start[k], width))
    for p in range(k):
        x_first[p], count = _fine_factors(x[p], r[p], reach[p], ratio[p], cell_size, n, binom, inv, xf, x_start[p])
        x_start[p + 1] = x_start[p] + count  # compacted as filled: never past the allocation
        y_first[p], count = _fine_factors(y[p], r[p], reach[p], ratio[p], cell_size, n, binom, inv, yf, y_start[p])
        y_start[p + 1] = y_start[p] + count
    return xf, x_first, x_start, yf, y_first, y_start


@numba.njit(cache=True)
def _binomials(width):
    binom = np.zeros((width, width))
    for i in range(width):
        binom[i, 0] = 1.0
        for q in range(1, i + 1):
            binom[i, q] = binom[i - 1, q - 1] + binom[i - 1, q]
    return binom


def add_to_tensor(tensor: np.ndarray, points: GaussPoints, lattice: Lattice,
               settings: PointSettings = PointSettings()) -> np.ndarray:
    """Add the polynomial points among ``points`` to ``tensor`` in place; remove with ``points.negated()``.

    Parameters
    ----------
    tensor : numpy.ndarray
        C-contiguous float64 ``(2^L, 2^L, 3, P + 1, P + 1)``, as from
        ``tensor.point_polynomials`` with the same lattice and settings.
    points : GaussPoints
        Near and dropped points among them are skipped (see ``near``).

    Returns
    -------
    numpy.ndarray
        ``(k, 4)`` fine-cell rectangles (rows ``[a, b)``, columns ``[c, d)``)
        the tensor changed in, one a point; empty for skipped points.
    """
    n, width = lattice.cells_per_side, settings.order + 1
    if tensor.shape != (n, n, 3, width, width) or tensor.dtype != np.float64 or not tensor.flags.c_contiguous:
        raise ValueError(f"tensor must be a C-contiguous float64 array of shape {(n, n, 3, width, width)}")
    ratios = expansion_ratios(points, lattice, settings)
    rectangles = changed_cells(points, lattice, settings)
    rectangles[ratios <= 0] = 0
    chosen = np.flatnonzero(ratios > 0)
    if len(chosen) == 0:
        return rectangles
    reach = cutoff_radii(points, settings.tolerance)[chosen]
    inv = 1.0 / np.maximum(np.arange(width), 1)
    picked = points.take(chosen)
    xf, x_first, x_start, yf, y_first, y_start = _all_factors(
        picked.positions[:, 0].copy(), picked.positions[:, 1].copy(), picked.radii, reach, ratios[chosen],
        float(lattice.cell_size), n, _binomials(width), inv)
    _add_products(tensor.reshape(n, n, 3 * width, width), picked.weights, xf, x_first, x_start, yf, y_first, y_start)
    return rectangles
