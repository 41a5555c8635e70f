"""Compiled (numba) sums of segment integrals; ``potentials`` holds the numpy reference.

The near field is the engine's bottleneck: plain numpy manages about 5 M
target-segment pairs per second here, these loops tens of times that
(``bench/bench_engine.py`` prints both).

Every kernel is built the same way: a target's values against a run of
segments go into a small scratch array in a loop that LLVM vectorises (the
branch-free ``segment_potentials``, with ``fastmath.POLY_MATH`` and
``error_model="numpy"``: see ``fastmath``), and a second vectorised loop
(``_weighted_sums``, compiled with reassociation) sums them.  Segments come
as a ``(7, n)`` table of rows (``segment_table``) so the loops read
contiguous memory; the near-field kernels copy a cell's 3x3 block of
segments into one such table, padded to a multiple of ``_PAD`` with
weightless copies so the vector loop has no scalar remainder, once for all
the targets in that cell (``near_sum`` visits its targets sorted by cell).

Rasters, whose samples form a tensor grid, have their own cell-by-cell
kernels in ``grid``.
"""

from __future__ import annotations

import numba
import numpy as np

from .fastmath import FAST_MATH, POLY_MATH, log_r2, potentials_from

#: The near-field blocks are padded to a multiple of this many segments (a vector loop's step).
_PAD = 8
#: Segments per scratch tile of the dense kernels.
_TILE = 512


@numba.njit(cache=True, inline="always", fastmath=POLY_MATH, error_model="numpy")
def segment_potentials(x: float, y: float, px: float, py: float, qx: float, qy: float, tx: float, ty: float, h: float):
    """Single and double layer of one segment at (x, y); see ``potentials``.

    Returns ``(S, D)``.  ``D`` is 0 on the segment's line outside it and at
    its end points; inside the segment the rounded cross product picks a side
    (+-1/2) unless it is exactly 0, so callers wanting the principal value
    there select 0 themselves, as the kernels below do for a segment's own
    midpoint.  This is ``fastmath.potentials_from`` given ``log|p - x|^2``:
    branch-free and without libm calls, so a loop calling it vectorises when
    compiled with ``fastmath=POLY_MATH, error_model="numpy"`` (it is inlined
    and takes its caller's options; see ``fastmath``).  Within about 2 ulp of
    libm in any caller; bit for bit equal to the kernels' values only in a
    caller compiled with those options.
    """
    single, double, _ = potentials_from(x, y, px, py, qx, qy, tx, ty, h, log_r2(x, y, px, py))
    return single, double


@numba.njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def _weighted_sums(single, double, weights, lo, hi, offset):
    """``sum_j weights[c, j] single[j - offset] - weights[3 + c, j] double[j - offset]``, j in [lo, hi), c < 3.

    Not inlined: its own reassociating flags let the sum vectorise, while the
    callers keep the polynomials' (``POLY_MATH``).
    """
    r = g = b = 0.0
    for j in range(lo, hi):
        s, d = single[j - offset], double[j - offset]
        r += weights[0, j] * s - weights[3, j] * d
        g += weights[1, j] * s - weights[4, j] * d
        b += weights[2, j] * s - weights[5, j] * d
    return r, g, b


@numba.njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def _sums(values, weights, lo, hi, offset):
    """``sum_j weights[c, j] values[j - offset]``, j in [lo, hi), c < 3 (reassociating, as above)."""
    r = g = b = 0.0
    for j in range(lo, hi):
        v = values[j - offset]
        r += weights[0, j] * v
        g += weights[1, j] * v
        b += weights[2, j] * v
    return r, g, b


def segment_frames(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents ``(n, 2)`` and lengths ``(n,)`` of segments."""
    d = q - p
    h = np.hypot(d[:, 0], d[:, 1])
    return d / h[:, None], h


def segment_table(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``(7, n)`` rows p_x, p_y, q_x, q_y, t_x, t_y, h: what ``segment_potentials`` takes, one contiguous row each."""
    tangent, length = segment_frames(p, q)
    table = np.empty((7, len(p)))
    table[0:2], table[2:4], table[4:6], table[6] = p.T, q.T, tangent.T, length
    return table


def _weights(flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
    """``(2 channels, n)`` rows: the channels of E, then of C."""
    return np.ascontiguousarray(np.concatenate([np.asarray(flux, np.float64).T, np.asarray(jump, np.float64).T]))


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _direct_sum(targets, table, weights, out):
    m, n = targets.shape[0], table.shape[1]
    per_block = 16
    for block in numba.prange((m + per_block - 1) // per_block):
        single = np.empty(_TILE)
        double = np.empty(_TILE)
        for i in range(block * per_block, min(m, (block + 1) * per_block)):
            x, y = targets[i, 0], targets[i, 1]
            r = g = b = 0.0
            for lo in range(0, n, _TILE):
                hi = min(n, lo + _TILE)
                for j in range(lo, hi):
                    single[j - lo], double[j - lo] = segment_potentials(
                        x, y, table[0, j], table[1, j], table[2, j], table[3, j], table[4, j], table[5, j], table[6, j]
                    )
                dr, dg, db = _weighted_sums(single, double, weights, lo, hi, lo)
                r += dr
                g += dg
                b += db
            out[i, 0], out[i, 1], out[i, 2] = r, g, b


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _pair_matrices(targets, table, single, double):
    for i in numba.prange(len(targets)):
        x, y = targets[i, 0], targets[i, 1]
        for j in range(table.shape[1]):
            single[i, j], double[i, j] = segment_potentials(
                x, y, table[0, j], table[1, j], table[2, j], table[3, j], table[4, j], table[5, j], table[6, j])


def pair_matrices(targets: np.ndarray, p: np.ndarray, q: np.ndarray,
                  single: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``S`` and ``D`` ``(m, n)`` of every segment at every target: the compiled ``potentials.pair_integrals``.

    Inside a segment the rounded cross product picks a side for ``D`` (see ``segment_potentials``): a caller
    wanting the principal value at a segment's own midpoint sets it to 0.  ``single``, when given, receives
    ``S`` in its first ``n`` columns (C-contiguous float64, ``m`` rows, at least ``n`` columns; the others are
    left as they are), so that a larger system is assembled where it lies; ``S`` is then a view of it.
    """
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    m, n = len(targets), len(p)
    if single is None:
        single = np.empty((m, n))
    elif not (single.dtype == np.float64 and single.flags.c_contiguous and single.ndim == 2
              and single.shape[0] == m and single.shape[1] >= n):
        raise ValueError(f"S needs a C-contiguous float64 array of {m} rows and {n} columns or more, "
                         f"not {single.dtype} {single.shape}")
    double = np.empty((m, n))
    _pair_matrices(targets, segment_table(p, q), single, double)
    return single[:, :n], double


def direct_sum(targets: np.ndarray, p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
    """``sum_j E_j S_j(x) - C_j D_j(x)`` over every segment, ``(m, 3)``.

    Compiled twin of ``potentials.direct_sum_reference`` (a target on a segment
    gets one side's value there, not the principal value).
    """
    out = np.empty((len(targets), 3))
    _direct_sum(np.ascontiguousarray(targets, dtype=np.float64), segment_table(p, q), _weights(flux, jump), out)
    return out


@numba.njit(cache=True)
def _block_size(cy, cx, n, cell_start):
    """Segments in the 3x3 block of cells around cell (cy, cx)."""
    first, last = max(cx - 1, 0), min(cx + 2, n)
    count = 0
    for row in range(max(cy - 1, 0), min(cy + 2, n)):
        count += cell_start[row * n + last] - cell_start[row * n + first]
    return count


@numba.njit(cache=True)
def _largest_block(n, cell_start):
    """The most segments in any 3x3 block of cells."""
    largest = 0
    for cy in range(n):
        for cx in range(n):
            largest = max(largest, _block_size(cy, cx, n, cell_start))
    return largest


@numba.njit(cache=True)
def _gather_block(cy, cx, n, cell_start, table, index, block, block_index):
    """Copy the 3x3 block's columns of ``table`` (and their ``index``) into ``block``, padded; the real count.

    The padding up to a multiple of ``_PAD`` repeats the last segment with
    index -1 (callers give it no weight).  ``block`` must hold the padded count.
    """
    first, last = max(cx - 1, 0), min(cx + 2, n)
    k = 0
    for row in range(max(cy - 1, 0), min(cy + 2, n)):
        for j in range(cell_start[row * n + first], cell_start[row * n + last]):
            for c in range(table.shape[0]):
                block[c, k] = table[c, j]
            block_index[k] = index[j]
            k += 1
    for pad in range(k, (k + _PAD - 1) // _PAD * _PAD):
        for c in range(table.shape[0]):
            block[c, pad] = block[c, k - 1]
        block_index[pad] = -1
    return k


@numba.njit(cache=True)
def _padded(count):
    """``count`` rounded up to a multiple of ``_PAD``."""
    return (count + _PAD - 1) // _PAD * _PAD


@numba.njit(cache=True)
def counting_sort(cell, cell_count):
    """Stable counting sort of ``cell`` (values below ``cell_count``): the order and CSR offsets
    ``(cell_count + 1,)``."""
    start = np.zeros(cell_count + 1, np.int64)
    for c in cell:
        start[c + 1] += 1
    for c in range(cell_count):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(len(cell), np.int64)
    for i in range(len(cell)):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return order, start


@numba.njit(parallel=True, cache=True)
def cells_of(targets, cells_per_side, cell_size):
    """Each target's fine cell ``row * cells_per_side + column``, clamped to the lattice."""
    n = cells_per_side
    cell = np.empty(targets.shape[0], np.int64)
    for i in numba.prange(targets.shape[0]):
        cx = min(max(int(targets[i, 0] / cell_size), 0), n - 1)
        cy = min(max(int(targets[i, 1] / cell_size), 0), n - 1)
        cell[i] = cy * n + cx
    return cell


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _near_sum(targets, cell, order, own, cells_per_side, cell_start, table, weights, out):
    n, m = cells_per_side, targets.shape[0]
    index = np.arange(table.shape[1])
    capacity = _padded(_largest_block(n, cell_start))
    per_block = 64
    for block_number in numba.prange((m + per_block - 1) // per_block):
        seg = np.empty((7, capacity))
        seg_index = np.empty(capacity, np.int64)
        seg_weights = np.empty((6, capacity))
        single = np.empty(capacity)
        double = np.empty(capacity)
        current, padded = -1, 0
        for t in range(block_number * per_block, min(m, (block_number + 1) * per_block)):
            i = order[t]
            if cell[i] != current:  # gather the block once for the targets of one cell
                current = cell[i]
                cy, cx = current // n, current % n
                count = _gather_block(cy, cx, n, cell_start, table, index, seg, seg_index)
                _gather_block(cy, cx, n, cell_start, weights, index, seg_weights, seg_index)
                padded = _padded(count)
                for k in range(count, padded):
                    for c in range(6):
                        seg_weights[c, k] = 0.0
            x, y, own_i = targets[i, 0], targets[i, 1], own[i]
            for k in range(padded):
                s, d = segment_potentials(x, y, seg[0, k], seg[1, k], seg[2, k], seg[3, k], seg[4, k], seg[5, k],
                                          seg[6, k])
                single[k] = s
                double[k] = 0.0 if seg_index[k] == own_i else d
            out[i, 0], out[i, 1], out[i, 2] = _weighted_sums(single, double, seg_weights, 0, padded, 0)


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
    tables: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Sum over the segments in the 3x3 cells around each target, ``(m, 3)``.

    Targets are taken cell by cell (a counting sort), so each cell's block
    of segments is gathered once for all its targets.

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
    tables : tuple of numpy.ndarray, optional
        ``near_tables(p, q, flux, jump)``, when kept from an earlier call.
    """
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    out = np.empty((len(targets), 3))
    own = np.full(len(targets), -1, np.int64) if own is None else np.asarray(own, np.int64)
    cell = cells_of(targets, int(cells_per_side), float(cell_size))
    order, _ = counting_sort(cell, int(cells_per_side) ** 2)
    table, weights = tables or near_tables(p, q, flux, jump)
    _near_sum(targets, cell, order, own, int(cells_per_side), np.asarray(cell_start, np.int64), table, weights, out)
    return out


def near_tables(p: np.ndarray, q: np.ndarray, flux: np.ndarray, jump: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What ``near_sum`` reads of the segments: ``segment_table(p, q)`` and the weights (E, then C)."""
    return segment_table(p, q), _weights(flux, jump)


@numba.njit(parallel=True, cache=True, fastmath=POLY_MATH, error_model="numpy")
def _collocation(mids, table, on_border, curve_jump, matrix, rhs):
    n = table.shape[1]
    per_block = 4
    for block in numba.prange((n + per_block - 1) // per_block):
        double = np.empty(_TILE)
        for i in range(block * per_block, min(n, (block + 1) * per_block)):
            x, y = mids[i, 0], mids[i, 1]
            row = matrix[i]
            r = g = b = 0.0
            for lo in range(0, n, _TILE):
                hi = min(n, lo + _TILE)
                for j in range(lo, hi):
                    s, d = segment_potentials(
                        x, y, table[0, j], table[1, j], table[2, j], table[3, j], table[4, j], table[5, j], table[6, j]
                    )
                    d = 0.0 if j == i else d  # principal value on the segment itself
                    row[j] = -d if on_border[j] else s
                    double[j - lo] = d
                dr, dg, db = _sums(double, curve_jump, lo, hi, lo)
                r += dr
                g += dg
                b += db
            if on_border[i]:
                row[i] -= 0.5
            rhs[i, 0] += r
            rhs[i, 1] += g
            rhs[i, 2] += b


def collocation_system(
    p: np.ndarray, q: np.ndarray, on_border: np.ndarray, jump: np.ndarray, mean: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Dense collocation matrix and right-hand sides; compiled twin of ``dense.assemble_reference``."""
    matrix = np.empty((len(p), len(p)))
    border = np.asarray(on_border, np.bool_)
    rhs = np.where(border[:, None], 0.0, mean)
    curve_jump = np.ascontiguousarray(np.where(border[:, None], 0.0, jump).T, dtype=np.float64)
    _collocation(0.5 * (p + q), segment_table(p, q), border, curve_jump, matrix, rhs)
    return matrix, rhs
