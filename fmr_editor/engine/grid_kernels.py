"""Compiled raster kernels: near and far field on a tensor grid of samples, cell by cell.

The twins of ``kernels.near_sum`` (arbitrary points) and ``raster.far_field``
(numpy); the tests compare them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .kernels import _TWO_PI, segment_frames


# --- Near field on a tensor grid of samples -------------------------------------------
#
# ``math.log`` and ``math.atan2`` compile to scalar libm calls, which keep LLVM
# from vectorising a loop (numba has no SVML here).  The two functions below are
# the classic fdlibm logarithm and Cephes arctangent in plain arithmetic, so a
# loop over samples vectorises; measured against libm they are within 1 ulp
# (log) and 2 ulp (atan2), the same rounding envelope as numpy's own
# (``layers.pair_integrals``).  The grid kernel is compiled without
# reassociation so their error bounds hold.

#: Fast-math flags of the grid kernel: no reassociation (the compensated sums below rely on order).
GRID_MATH = {"nsz", "contract"}

_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01


@numba.njit(cache=True, inline="always", fastmath=GRID_MATH, error_model="numpy")
def _log_poly(x):
    """``log(x)`` for finite normal ``x > 0`` without a libm call (fdlibm ``__ieee754_log``).

    ``x = 2^k m`` with ``m`` in ``[sqrt(2)/2, sqrt(2))``; ``log m`` from
    ``s = f / (2 + f)``, ``f = m - 1``, and a degree-14 odd polynomial.
    """
    bits = np.float64(x).view(np.int64) + (0x3FF0000000000000 - 0x3FE6A09E00000000)
    k = (bits >> 52) - 0x3FF
    m = np.int64((bits & 0x000FFFFFFFFFFFFF) + 0x3FE6A09E00000000).view(np.float64)
    f = m - 1.0
    half_f2 = 0.5 * f * f
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    even = w * (_LG2 + w * (_LG4 + w * _LG6))
    odd = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    dk = np.float64(k)
    return s * (half_f2 + odd + even) + dk * _LN2_LO - half_f2 + f + dk * _LN2_HI


_ATAN_P0 = -8.750608600031904122785e-1
_ATAN_P1 = -1.615753718733365076637e1
_ATAN_P2 = -7.500855792314704667340e1
_ATAN_P3 = -1.228866684490136173410e2
_ATAN_P4 = -6.485021904942025371773e1
_ATAN_Q0 = 2.485846490142306297962e1
_ATAN_Q1 = 1.650270098316988542046e2
_ATAN_Q2 = 4.328810604912902668951e2
_ATAN_Q3 = 4.853903996359136964868e2
_ATAN_Q4 = 1.945506571482613964425e2
#: pi/2 minus its double (the low part Cephes adds back).
_PI_2_LO = 6.123233995736765886130e-17


@numba.njit(cache=True, inline="always", fastmath=GRID_MATH, error_model="numpy")
def _atan2_poly(y, x):
    """``atan2(y, x)`` without a libm call (Cephes ``atan`` on ``min/max`` of ``|x|, |y|``).

    NaN when ``x == y == 0``; callers select 0 there, as ``_layers`` does.
    """
    ax, ay = abs(x), abs(y)
    lo, hi = min(ax, ay), max(ax, ay)
    big = lo > 0.66 * hi
    t = (lo - hi) / (lo + hi) if big else lo / hi
    z = t * t
    num = (((_ATAN_P0 * z + _ATAN_P1) * z + _ATAN_P2) * z + _ATAN_P3) * z + _ATAN_P4
    den = ((((z + _ATAN_Q0) * z + _ATAN_Q1) * z + _ATAN_Q2) * z + _ATAN_Q3) * z + _ATAN_Q4
    r = t + t * (z * num / den)
    if big:
        r = 0.25 * math.pi + (r + 0.5 * _PI_2_LO)
    if ay > ax:
        r = (0.5 * math.pi - r) + _PI_2_LO
    if x < 0.0:
        r = (math.pi - r) + 2.0 * _PI_2_LO
    if y < 0.0:
        r = -r
    return r


_INV_TWO_PI = 1.0 / _TWO_PI
_INV_FOUR_PI = 0.5 / _TWO_PI


@numba.njit(cache=True, inline="always", fastmath=GRID_MATH, error_model="numpy")
def _layers_grid(x, y, px, py, qx, qy, tx, ty, h, log_p):
    """``_layers`` given ``log|p - x|^2``, with the functions above; also returns ``log|q - x|^2``.

    The closed form and the guards are those of ``_layers``; consecutive
    segments of a curve share an end point, so the caller passes one
    segment's ``log_q`` on as the next one's ``log_p``.
    """
    v0x, v0y = px - x, py - y
    v1x, v1y = qx - x, qy - y
    a = -(v0x * tx + v0y * ty)
    b_abs = abs(v0x * ty - v0y * tx)
    cross = v0x * v1y - v0y * v1x
    dot = v0x * v1x + v0y * v1y
    angle = _atan2_poly(cross, dot)
    if not (cross != 0.0 or dot > 0.0):
        angle = 0.0
    log_q = _log_poly(max(v1x * v1x + v1y * v1y, 1e-300))
    single = ((h - a) * log_q + a * log_p - 2.0 * h + 2.0 * b_abs * abs(angle)) * _INV_FOUR_PI
    return single, angle * _INV_TWO_PI, log_q


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
                v0x, v0y = px - sx[i], py - sy[i]
                logs[current, i] = _log_poly(max(v0x * v0x + v0y * v0y, 1e-300))
        log_p, log_q = logs[current], logs[1 - current]
        for i in range(count):
            s, d, log_q[i] = _layers_grid(sx[i], sy[i], px, py, qx, qy, tx, ty, h, log_p[i])
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


def grid_cell_runs(coords: np.ndarray, cell_size: float, cells_per_side: int) -> np.ndarray:
    """Offsets ``(cells_per_side + 1,)`` of each fine cell's run in sorted coordinates along one axis.

    A coordinate's cell is ``floor(coord / cell_size)`` clamped to the lattice,
    as in ``raster.far_field``: a sample on an edge between two cells belongs
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
    xs = np.ascontiguousarray(xs, dtype=np.float64)
    ys = np.ascontiguousarray(ys, dtype=np.float64)
    if (np.diff(xs) < 0).any() or (np.diff(ys) < 0).any():
        raise ValueError("grid coordinates must be sorted")
    shape = (len(ys), len(xs), 3)
    if out is None:
        out = np.zeros(shape)
    elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous float64 array of shape {shape}")
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

    Compiled twin of ``raster.far_field``.

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
