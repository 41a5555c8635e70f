"""Compiled (numba) sums of segment integrals; ``layers`` holds the numpy reference.

The near field is the engine's bottleneck: plain numpy manages about 5 M
target-segment pairs per second here, these loops several times that
(``bench/bench_engine.py`` prints both).

Rasters, whose samples form a tensor grid, have their own cell-by-cell
kernels in ``grid_kernels``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_TWO_PI = 2.0 * math.pi
#: Fast-math flags without "no NaNs / no infinities", so the guards below keep working.
FAST_MATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


@numba.njit(cache=True, inline="always", fastmath=FAST_MATH)
def _layers(x: float, y: float, px: float, py: float, qx: float, qy: float, tx: float, ty: float, h: float):
    """Single and double layer of one segment at (x, y); see ``layers``.

    The two arctangents of the single layer differ by the angle the segment
    subtends, which the double layer computes anyway, so one ``atan2`` and
    two logarithms serve both (``layers.pair_integrals`` is the plain form).
    """
    v0x, v0y = px - x, py - y
    v1x, v1y = qx - x, qy - y
    a = -(v0x * tx + v0y * ty)
    b_abs = abs(v0x * ty - v0y * tx)
    cross = v0x * v1y - v0y * v1x
    dot = v0x * v1x + v0y * v1y
    angle = 0.0
    if cross != 0.0 or dot > 0.0:
        angle = math.atan2(cross, dot)
    log_p = math.log(max(v0x * v0x + v0y * v0y, 1e-300))
    log_q = math.log(max(v1x * v1x + v1y * v1y, 1e-300))
    single = ((h - a) * log_q + a * log_p - 2.0 * h + 2.0 * b_abs * abs(angle)) / (2.0 * _TWO_PI)
    return single, angle / _TWO_PI


def segment_frames(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents ``(n, 2)`` and lengths ``(n,)`` of segments."""
    d = q - p
    h = np.hypot(d[:, 0], d[:, 1])
    return d / h[:, None], h


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def _direct_sum(targets, p, q, tangent, length, flux, jump, out):
    for i in numba.prange(targets.shape[0]):
        x, y = targets[i, 0], targets[i, 1]
        r = g = b = 0.0
        for j in range(p.shape[0]):
            s, d = _layers(x, y, p[j, 0], p[j, 1], q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1], length[j])
            r += flux[j, 0] * s - jump[j, 0] * d
            g += flux[j, 1] * s - jump[j, 1] * d
            b += flux[j, 2] * s - jump[j, 2] * d
        out[i, 0], out[i, 1], out[i, 2] = r, g, b


def direct_sum(targets: np.ndarray, p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
    """``sum_j E_j S_j(x) - C_j D_j(x)`` over every segment, ``(m, 3)``.

    Compiled twin of ``layers.direct_sum_reference``.
    """
    tangent, length = segment_frames(p, q)
    out = np.empty((len(targets), 3))
    _direct_sum(np.ascontiguousarray(targets, dtype=np.float64), p, q, tangent, length, flux, jump, out)
    return out


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def _near_sum(targets, own, cells_per_side, cell_size, cell_start, p, q, tangent, length, flux, jump, out):
    n = cells_per_side
    for i in numba.prange(targets.shape[0]):
        x, y = targets[i, 0], targets[i, 1]
        cx = min(max(int(x / cell_size), 0), n - 1)
        cy = min(max(int(y / cell_size), 0), n - 1)
        r = g = b = 0.0
        for ny in range(max(cy - 1, 0), min(cy + 2, n)):
            for nx in range(max(cx - 1, 0), min(cx + 2, n)):
                cell = ny * n + nx
                for j in range(cell_start[cell], cell_start[cell + 1]):
                    s, d = _layers(x, y, p[j, 0], p[j, 1], q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1], length[j])
                    if j == own[i]:
                        d = 0.0
                    r += flux[j, 0] * s - jump[j, 0] * d
                    g += flux[j, 1] * s - jump[j, 1] * d
                    b += flux[j, 2] * s - jump[j, 2] * d
        out[i, 0], out[i, 1], out[i, 2] = r, g, b


def near_sum(
    targets: np.ndarray,
    cells_per_side: int,
    cell_size: float,
    cell_start: np.ndarray,
    p: np.ndarray,
    q: np.ndarray,
    flux: np.ndarray,
    jump: np.ndarray,
    own: np.ndarray | None = None,
) -> np.ndarray:
    """Sum over the segments in the 3x3 cells around each target, ``(m, 3)``.

    Parameters
    ----------
    targets : numpy.ndarray
        ``(m, 2)`` points in document pixels.
    cells_per_side : int
        Fine lattice size ``2^L``.
    cell_size : float
        Fine cell size in pixels.
    cell_start : numpy.ndarray
        ``(cells_per_side**2 + 1,)`` offsets: the segments of cell
        ``row * cells_per_side + column`` are ``cell_start[c]:cell_start[c+1]``.
    p, q, flux, jump : numpy.ndarray
        Segments sorted by cell.
    own : numpy.ndarray, optional
        ``(m,)`` index of a segment each target lies on (its midpoint), whose
        double layer then counts as 0 (the principal value); -1 for none.
    """
    tangent, length = segment_frames(p, q)
    out = np.empty((len(targets), 3))
    own = np.full(len(targets), -1, np.int64) if own is None else np.asarray(own, np.int64)
    _near_sum(
        np.ascontiguousarray(targets, dtype=np.float64), own,
        cells_per_side, float(cell_size), cell_start, p, q, tangent, length, flux, jump, out,
    )
    return out


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def _collocation(mids, p, q, tangent, length, on_border, curve_jump, matrix, rhs):
    n = p.shape[0]
    for i in numba.prange(n):
        x, y = mids[i, 0], mids[i, 1]
        for j in range(n):
            s, d = _layers(x, y, p[j, 0], p[j, 1], q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1], length[j])
            if i == j:
                d = 0.0
            if on_border[j]:
                matrix[i, j] = -d
            else:
                matrix[i, j] = s
                for c in range(3):
                    rhs[i, c] += d * curve_jump[j, c]
        if on_border[i]:
            matrix[i, i] -= 0.5


def collocation_system(
    p: np.ndarray, q: np.ndarray, on_border: np.ndarray, jump: np.ndarray, mean: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Dense collocation matrix and right-hand sides; compiled twin of ``bem.assemble_reference``."""
    tangent, length = segment_frames(p, q)
    matrix = np.empty((len(p), len(p)))
    rhs = np.where(on_border[:, None], 0.0, mean)
    _collocation(0.5 * (p + q), p, q, tangent, length, on_border, np.ascontiguousarray(jump), matrix, rhs)
    return matrix, rhs


@numba.njit(parallel=True, cache=True)
def _near_row_counts(cells, cells_per_side, cell_start, counts):
    n = cells_per_side
    for i in numba.prange(cells.shape[0]):
        cy, cx = cells[i, 0], cells[i, 1]
        total = 0
        for ny in range(max(cy - 1, 0), min(cy + 2, n)):
            for nx in range(max(cx - 1, 0), min(cx + 2, n)):
                total += cell_start[ny * n + nx + 1] - cell_start[ny * n + nx]
        counts[i] = total


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def _near_entries(cells, cells_per_side, cell_start, p, q, tangent, length, on_border, row_start, columns, values):
    n = cells_per_side
    for i in numba.prange(p.shape[0]):
        x, y = 0.5 * (p[i, 0] + q[i, 0]), 0.5 * (p[i, 1] + q[i, 1])
        cy, cx = cells[i, 0], cells[i, 1]
        k = row_start[i]
        for ny in range(max(cy - 1, 0), min(cy + 2, n)):
            for nx in range(max(cx - 1, 0), min(cx + 2, n)):
                cell = ny * n + nx
                for j in range(cell_start[cell], cell_start[cell + 1]):
                    s, d = _layers(x, y, p[j, 0], p[j, 1], q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1], length[j])
                    if j == i:
                        d = 0.0
                    value = -d if on_border[j] else s
                    if j == i and on_border[i]:
                        value -= 0.5
                    columns[k] = j
                    values[k] = value
                    k += 1


def near_block(
    cells: np.ndarray, cells_per_side: int, cell_start: np.ndarray, p: np.ndarray, q: np.ndarray, on_border: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The collocation matrix restricted to each row's 3x3 block, as CSR arrays.

    Returns ``(row_start, columns, values)``; the entries equal those of the
    dense ``bem.assemble`` at the same positions.
    """
    counts = np.empty(len(p), np.int64)
    _near_row_counts(cells, cells_per_side, cell_start, counts)
    row_start = np.concatenate([[0], np.cumsum(counts)])
    columns = np.empty(row_start[-1], np.int64)
    values = np.empty(row_start[-1])
    tangent, length = segment_frames(p, q)
    _near_entries(cells, cells_per_side, cell_start, p, q, tangent, length, on_border, row_start, columns, values)
    return row_start, columns, values
