"""Compiled raster kernels: near and far field on a tensor grid of samples, cell by cell.

The twins of ``segment_sums.near_sum`` (arbitrary points) and ``raster.far_field_reference``
(numpy); the tests compare them.
"""

from __future__ import annotations

import numba
import numpy as np

from .fastmath import POLY_MATH, log_r2, potentials_from
from .segment_sums import segment_frames

# --- Near field on a tensor grid of samples -------------------------------------------
#
# The inner loops run over a cell's samples and call ``fastmath``'s
# branch-free, libm-free ``potentials_from``, so they vectorise.  They are
# compiled without reassociation (``POLY_MATH``) so the polynomials' error
# bounds hold, and with ``error_model="numpy"`` (see ``fastmath``).

#: Fast-math flags of the grid kernels: no reassociation (the compensated sums rely on order).
GRID_MATH = POLY_MATH


@numba.njit(cache=True, fastmath=GRID_MATH, error_model="numpy")
def _near_cell(cy, cx, xs, ys, x_start, y_start, n, cell_start, p, q, tangent, length, flux, jump, out):
    """Add the near field of fine cell (cy, cx) to its samples ``out[y_start[cy]:..., x_start[cx]:...]``.

    The 3x3 block's segments are gathered once into a contiguous table and the
    cell's samples into flat coordinate arrays; the inner loop runs over
    samples (it vectorises), the outer one over segments.
    """
    ya, yb = y_start[cy], y_start[cy + 1]
    xa, xb = x_start[cx], x_start[cx + 1]
    width = xb - xa
    count = (yb - ya) * width
    first, last = max(cx - 1, 0), min(cx + 2, n)
    m = 0
    for row in range(max(cy - 1, 0), min(cy + 2, n)):
        m += cell_start[row * n + last] - cell_start[row * n + first]
    if m == 0 or count == 0:
        return
    # columns: p, q, tangent, length, flux, jump
    seg = np.empty((m, 13))
    shares_p = np.zeros(m, np.bool_)
    k = 0
    for row in range(max(cy - 1, 0), min(cy + 2, n)):
        for j in range(cell_start[row * n + first], cell_start[row * n + last]):
            seg[k, 0], seg[k, 1], seg[k, 2], seg[k, 3] = p[j, 0], p[j, 1], q[j, 0], q[j, 1]
            seg[k, 4], seg[k, 5], seg[k, 6] = tangent[j, 0], tangent[j, 1], length[j]
            for c in range(3):
                seg[k, 7 + c] = flux[j, c]
                seg[k, 10 + c] = jump[j, c]
            shares_p[k] = k > 0 and seg[k, 0] == seg[k - 1, 2] and seg[k, 1] == seg[k - 1, 3]
            k += 1
    sx = np.empty(count)
    sy = np.empty(count)
    for a in range(yb - ya):
        for b in range(width):
            sx[a * width + b] = xs[xa + b]
            sy[a * width + b] = ys[ya + a]
    acc = np.zeros((3, count))
    logs = np.empty((2, count))
    current = 0
    for k in range(m):
        px, py, qx, qy = seg[k, 0], seg[k, 1], seg[k, 2], seg[k, 3]
        tx, ty, h = seg[k, 4], seg[k, 5], seg[k, 6]
        e0, e1, e2, c0, c1, c2 = seg[k, 7], seg[k, 8], seg[k, 9], seg[k, 10], seg[k, 11], seg[k, 12]
        if shares_p[k]:
            current = 1 - current  # the previous segment's log at q is this one's log at p
        else:
            for i in range(count):
                logs[current, i] = log_r2(sx[i], sy[i], px, py)
        log_p, log_q = logs[current], logs[1 - current]
        for i in range(count):
            s, d, log_q[i] = potentials_from(sx[i], sy[i], px, py, qx, qy, tx, ty, h, log_p[i])
            acc[0, i] += e0 * s - c0 * d
            acc[1, i] += e1 * s - c1 * d
            acc[2, i] += e2 * s - c2 * d
    for a in range(yb - ya):
        for b in range(width):
            for c in range(3):
                out[ya + a, xa + b, c] += acc[c, a * width + b]


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _near_grid(xs, ys, x_start, y_start, n, cell_start, p, q, tangent, length, flux, jump, cells, group_start, out):
    for g in numba.prange(group_start.shape[0] - 1):
        for item in range(group_start[g], group_start[g + 1]):
            cell = cells[item]
            _near_cell(cell // n, cell % n, xs, ys, x_start, y_start, n, cell_start,
                       p, q, tangent, length, flux, jump, out)


def grid_arrays(xs: np.ndarray, ys: np.ndarray, out: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked grid coordinates (contiguous, sorted) and an output ``(len(ys), len(xs), 3)`` to add to.

    Raises ``ValueError`` for unsorted coordinates or an ``out`` of the wrong
    shape, type or layout; a missing ``out`` is zeros.
    """
    xs = np.ascontiguousarray(xs, dtype=np.float64)
    ys = np.ascontiguousarray(ys, dtype=np.float64)
    if (np.diff(xs) < 0).any() or (np.diff(ys) < 0).any():
        raise ValueError("grid coordinates must be sorted")
    shape = (len(ys), len(xs), 3)
    if out is None:
        out = np.zeros(shape)
    elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous float64 array of shape {shape}")
    return xs, ys, out


def grid_cell_runs(coords: np.ndarray, cell_size: float, cells_per_side: int) -> np.ndarray:
    """Offsets ``(cells_per_side + 1,)`` of each fine cell's run in sorted coordinates along one axis.

    A coordinate's cell is ``floor(coord / cell_size)`` clamped to the lattice,
    as in ``raster.far_field_reference``: a sample on an edge between two cells belongs
    to the one with the larger index.
    """
    cells = np.clip(np.floor(coords / cell_size).astype(np.int64), 0, cells_per_side - 1)
    return np.searchsorted(cells, np.arange(cells_per_side + 1)).astype(np.int64)


def near_field_grid(
    xs: np.ndarray,
    ys: np.ndarray,
    cells_per_side: int,
    cell_size: float,
    cell_start: np.ndarray,
    p: np.ndarray,
    q: np.ndarray,
    flux: np.ndarray,
    jump: np.ndarray,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """``near_sum`` on the tensor grid ``ys x xs``, ``(len(ys), len(xs), 3)``.

    Works cell by cell: each fine cell's run of samples against its 3x3
    block's segments, gathered once; threads take groups of cells of about
    equal cost.

    Parameters
    ----------
    xs, ys : numpy.ndarray
        Sorted (non-decreasing) sample coordinates in document pixels.
    cells_per_side, cell_size, cell_start, p, q, flux, jump
        As for ``near_sum``: the lattice and the segments sorted by cell.
    out : numpy.ndarray, optional
        ``(len(ys), len(xs), 3)`` float64 C-contiguous; the near field is
        *added* to it (the far field, say) and it is returned.
    """
    xs, ys, out = grid_arrays(xs, ys, out)
    n = int(cells_per_side)
    if out.size == 0 or len(p) == 0:
        return out
    x_start = grid_cell_runs(xs, cell_size, n)
    y_start = grid_cell_runs(ys, cell_size, n)
    counts = np.diff(cell_start).reshape(n, n)
    padded = np.pad(counts, 1)
    block = sum(padded[1 + dy : 1 + dy + n, 1 + dx : 1 + dx + n] for dy in (-1, 0, 1) for dx in (-1, 0, 1))
    # a cell costs about its samples x (its block's segments + 1); empty blocks are skipped
    cost = np.where(block > 0, block + 1, 0) * np.diff(y_start)[:, None] * np.diff(x_start)[None, :]
    cells = np.flatnonzero(cost)
    if len(cells) == 0:
        return out
    total = np.cumsum(cost.ravel()[cells])
    groups = max(1, min(numba.get_num_threads(), len(cells)))
    bounds = np.searchsorted(total, total[-1] * np.arange(1, groups) / groups)
    group_start = np.concatenate([[0], bounds, [len(cells)]]).astype(np.int64)
    tangent, length = segment_frames(p, q)
    _near_grid(xs, ys, x_start, y_start, n, cell_start, p, q, tangent, length,
               np.ascontiguousarray(flux, dtype=np.float64), np.ascontiguousarray(jump, dtype=np.float64),
               cells, group_start, out)
    return out


# --- Far field (cell polynomials) on a tensor grid ----------------------------------------


@numba.njit(parallel=True, cache=True, fastmath=GRID_MATH, error_model="numpy")
def _far_grid(poly, xs, ys, x_start, y_start, cell_size, out):
    """Horner in eta, then in xi; the inner loops run over a cell's samples so they vectorise."""
    n, degree = poly.shape[0], poly.shape[-1] - 1
    for cy in numba.prange(n):
        ya, yb = y_start[cy], y_start[cy + 1]
        rows = yb - ya
        if rows == 0:
            continue
        eta = np.empty(rows)
        for a in range(rows):
            eta[a] = ys[ya + a] / cell_size - (cy + 0.5)
        partial = np.empty((degree + 1, rows))
        xi = np.empty(x_start[n] - x_start[0])
        values = np.empty_like(xi)
        for cx in range(n):
            xa, xb = x_start[cx], x_start[cx + 1]
            cols = xb - xa
            if cols == 0:
                continue
            for b in range(cols):
                xi[b] = xs[xa + b] / cell_size - (cx + 0.5)
            for c in range(3):
                coeffs = poly[cy, cx, c]
                # partial[i, a] = sum_j coeffs[i, j] eta_a^j
                for i in range(degree + 1):
                    for a in range(rows):
                        partial[i, a] = coeffs[i, degree]
                    for j in range(degree - 1, -1, -1):
                        for a in range(rows):
                            partial[i, a] = partial[i, a] * eta[a] + coeffs[i, j]
                # value[a, b] = sum_i partial[i, a] xi_b^i
                for a in range(rows):
                    for b in range(cols):
                        values[b] = partial[degree, a]
                    for i in range(degree - 1, -1, -1):
                        for b in range(cols):
                            values[b] = values[b] * xi[b] + partial[i, a]
                    for b in range(cols):
                        out[ya + a, xa + b, c] = values[b]


def far_field_grid(poly: np.ndarray, xs: np.ndarray, ys: np.ndarray, cell_size: float) -> np.ndarray:
    """Cell polynomials on the tensor grid ``ys x xs``, ``(len(ys), len(xs), 3)``.

    Compiled twin of ``raster.far_field_reference``.

    Parameters
    ----------
    poly : numpy.ndarray
        ``(n, n, 3, p + 1, p + 1)`` coefficients of ``xi^i eta^j``, ``(xi, eta)``
        the position in the cell relative to its centre, in cell sizes.
    xs, ys : numpy.ndarray
        Sorted (non-decreasing) sample coordinates in document pixels.
    """
    xs = np.ascontiguousarray(xs, dtype=np.float64)
    ys = np.ascontiguousarray(ys, dtype=np.float64)
    if (np.diff(xs) < 0).any() or (np.diff(ys) < 0).any():
        raise ValueError("grid coordinates must be sorted")
    n = poly.shape[0]
    out = np.empty((len(ys), len(xs), 3))
    _far_grid(np.ascontiguousarray(poly, dtype=np.float64), xs, ys,
              grid_cell_runs(xs, cell_size, n), grid_cell_runs(ys, cell_size, n), float(cell_size), out)
    return out
