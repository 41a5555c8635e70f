"""Compiled raster kernels: near and far field on a tensor grid of samples, by rows of cells.

The twins of ``segment_sums.near_sum`` (arbitrary points) and ``raster.far_field_reference``
(numpy); the tests compare them.
"""

from __future__ import annotations

import numba
import numpy as np

from .blocks import GEOMETRY, by_samples, by_samples4, gather_block
from .fastmath import POLY_MATH
from .near_rows import near_rows
from .rows import spread_rows
from .segment_sums import near_tables
from .single import SINGLE_BUDGET, by_samples_single, by_samples_single4, error_bounds, gather_single

# --- Near field on a tensor grid of samples -------------------------------------------
#
# The inner loops run over a cell's samples and call ``fastmath``'s
# branch-free, libm-free ``potentials_from``, so they vectorise.  They are
# compiled without reassociation (``POLY_MATH``) so the polynomials' error
# bounds hold, and with ``error_model="numpy"`` (see ``fastmath``).

#: Fast-math flags of the grid kernels: no reassociation (the compensated sums rely on order).
GRID_MATH = POLY_MATH
#: Lattices whose cells hold at most this many samples a side sum their near field in ``near_rows``.
ROW_SAMPLES = 2


# Each count of channels (3 or 4) has kernels of its own, made by the factories below, in which the fourth
# channel's lines fold away or stay (``blocks.samples_loop``): three channels run as they always did.  A cached
# kernel's closure holds its constants alone, the kernels it calls being module globals: numba keys a closure's
# cache by its closure's values, and a compiled function among them pickles differently in every process.


def _samples_single_of(channels):
    """``samples_single`` of ``channels``: ``blocks.by_samples`` through ``single``'s float32 loop about (xc, yc)
    into the float64 ``acc (channels, count)``; samples with a pair in doubt (``single.doubt_single``) are summed
    again in float64."""
    double_loop, single_loop = (by_samples4, by_samples_single4) if channels == 4 else (by_samples, by_samples_single)

    @numba.njit(inline="always", fastmath=GRID_MATH, error_model="numpy")
    def samples_single(m, count, xc, yc, cell_size, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful, scratch):
        block, sx32, sy32, acc32, logs32, terms = scratch
        inv_size = 1.0 / cell_size
        gather_single(m, seg, xc, yc, inv_size, cell_size, block, terms, channels)
        for i in range(count):
            sx32[i] = np.float32((sx[i] - xc) * inv_size)
            sy32[i] = np.float32((sy[i] - yc) * inv_size)
            doubtful[i] = 0
        single_loop(m, count, block, shares_p, flux_free, sx32, sy32, acc32, logs32, doubtful)
        for c in range(channels):
            t = terms[c]
            for i in range(count):
                acc[c, i] = acc32[c, i] + t
        for i in range(count):
            if doubtful[i]:
                double_loop(m, 1, seg, shares_p, flux_free, sx[i:], sy[i:], acc[:, i:], logs, doubtful)

    return samples_single


_samples_single3, _samples_single4 = _samples_single_of(3), _samples_single_of(4)


def _near_row_of(channels):
    """``near_row`` of ``channels``."""
    four = channels == 4

    @numba.njit(cache=True, fastmath=GRID_MATH, error_model="numpy")
    def near_row(cy, xs, ys, x_start, y_start, n, cell_start, cell_size, table, weights, single, skip, out, seg,
                 shares_p, flux_free, sx, sy, acc, logs, doubtful, scratch):
        """Add the near field of the samples of cell row ``cy``, one column of segments at a time.

        The samples of cells ``cx - 1`` to ``cx + 1`` of the row (a window) see the
        segments of cells ``cx`` in rows ``cy - 1`` to ``cy + 1`` (a column): over
        all ``cx`` that is each sample against its 3x3 block.  ``single[cy, cx]``:
        the visit runs in float32.  A window leaves out the cells at its ends where ``skip`` (``(n, n)``, or
        ``(0, 0)``: none).  The rest are the thread's scratch arrays.
        """
        ya, yb = y_start[cy], y_start[cy + 1]
        rows = yb - ya
        skipping = skip.shape[0] > 0
        for cx in range(n):
            first, last = max(cx - 1, 0), min(cx + 2, n)
            if skipping:
                while first < last and skip[cy, first]:
                    first += 1
                while last > first and skip[cy, last - 1]:
                    last -= 1
            xa, xb = x_start[first], x_start[last]
            width = xb - xa
            if width == 0:
                continue
            m = gather_block(cy, cx, cx + 1, n, cell_start, table, weights, seg, shares_p, flux_free)
            if m == 0:
                continue
            count = rows * width
            for a in range(rows):
                for b in range(width):
                    sx[a * width + b] = xs[xa + b]
                    sy[a * width + b] = ys[ya + a]
            xc, yc = (cx + 0.5) * cell_size, (cy + 0.5) * cell_size
            if single[cy, cx] and four:
                _samples_single4(m, count, xc, yc, cell_size, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful,
                                 scratch)
            elif single[cy, cx]:
                _samples_single3(m, count, xc, yc, cell_size, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful,
                                 scratch)
            elif four:
                by_samples4(m, count, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful)
            else:
                by_samples(m, count, seg, shares_p, flux_free, sx, sy, acc, logs, doubtful)
            for a in range(rows):
                for b in range(width):
                    for c in range(channels):
                        out[ya + a, xa + b, c] += acc[c, a * width + b]

    return near_row


_near_row3, _near_row4 = _near_row_of(3), _near_row_of(4)


def _near_grid_of(channels):
    """``near_grid`` of ``channels``: threads take rows of cells (``rows.spread_rows``); each writes its own
    samples."""
    four = channels == 4
    rows = GEOMETRY + 2 * channels

    @numba.njit(parallel=True, cache=True, error_model="numpy")
    def near_grid(xs, ys, x_start, y_start, n, cell_start, cell_size, table, weights, capacity, most, single,
                  any_single, skip, out):
        spread = spread_rows(y_start)
        for t in numba.prange(len(spread)):
            cy = spread[t]
            lo, hi = max(cy - 1, 0), min(cy + 2, n)
            if y_start[cy] == y_start[cy + 1] or cell_start[lo * n] == cell_start[hi * n]:
                continue
            seg = np.empty((rows, capacity))
            shares_p, flux_free = np.empty(capacity, np.bool_), np.empty(capacity, np.bool_)
            sx, sy = np.empty(most), np.empty(most)
            acc, logs, doubtful = np.empty((channels, most)), np.empty((2, most)), np.zeros(most, np.int32)
            most32 = most if any_single else 0
            scratch = (np.empty((rows, capacity), np.float32), np.empty(most32, np.float32),
                       np.empty(most32, np.float32), np.empty((channels, most32), np.float32),
                       np.empty((2, most32), np.float32), np.empty(channels))
            if four:
                _near_row4(cy, xs, ys, x_start, y_start, n, cell_start, cell_size, table, weights, single, skip, out,
                           seg, shares_p, flux_free, sx, sy, acc, logs, doubtful, scratch)
            else:
                _near_row3(cy, xs, ys, x_start, y_start, n, cell_start, cell_size, table, weights, single, skip, out,
                           seg, shares_p, flux_free, sx, sy, acc, logs, doubtful, scratch)

    return near_grid


#: The near field's kernel of each count of channels.
_NEAR_GRID = {channels: _near_grid_of(channels) for channels in (3, 4)}


def grid_arrays(xs: np.ndarray, ys: np.ndarray, out: np.ndarray | None,
                channels: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked grid coordinates (contiguous, sorted) and an output ``(len(ys), len(xs), channels)`` to add to.

    Raises ``ValueError`` for unsorted coordinates or an ``out`` of the wrong
    shape, type or layout; a missing ``out`` is zeros.
    """
    xs = np.ascontiguousarray(xs, dtype=np.float64)
    ys = np.ascontiguousarray(ys, dtype=np.float64)
    if not (_non_decreasing(xs) and _non_decreasing(ys)):
        raise ValueError("grid coordinates must be sorted")
    shape = (len(ys), len(xs), channels)
    if out is None:
        out = np.zeros(shape)
    elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous float64 array of shape {shape}")
    return xs, ys, out


@numba.njit(parallel=True, cache=True)
def cells_all(flags: np.ndarray, x_start: np.ndarray, y_start: np.ndarray) -> np.ndarray:
    """``(n, n)`` bool: cells all of whose samples are ``flags (len(ys), len(xs))`` (those with none too), the cells'
    runs of samples ``x_start``, ``y_start`` (``grid_cell_runs``)."""
    n = len(x_start) - 1
    cells = np.ones((n, n), np.bool_)
    spread = spread_rows(y_start)
    for t in numba.prange(len(spread)):
        cy = spread[t]
        for i in range(y_start[cy], y_start[cy + 1]):
            for cx in range(n):
                if cells[cy, cx]:
                    for j in range(x_start[cx], x_start[cx + 1]):
                        if not flags[i, j]:
                            cells[cy, cx] = False
                            break
    return cells


@numba.njit(parallel=True, cache=True)
def _fill_cells(out, cells, values, x_start, y_start):
    n = cells.shape[0]
    spread = spread_rows(y_start)
    for t in numba.prange(len(spread)):
        cy = spread[t]
        for cx in range(n):
            if cells[cy, cx]:
                for a in range(y_start[cy], y_start[cy + 1]):
                    for b in range(x_start[cx], x_start[cx + 1]):
                        for c in range(out.shape[2]):
                            out[a, b, c] = values[cy, cx]


def fill_cells(out: np.ndarray, cells: np.ndarray, values: np.ndarray, xs: np.ndarray, ys: np.ndarray,
               cell_size: float) -> None:
    """Set every channel of the samples of the grid ``ys x xs`` (``out (len(ys), len(xs), channels)``) in the
    ``cells (n, n)`` bool to their cell's ``values (n, n)``."""
    n = cells.shape[0]
    _fill_cells(out, np.ascontiguousarray(cells, np.bool_), np.ascontiguousarray(values, np.float64),
                grid_cell_runs(xs, cell_size, n), grid_cell_runs(ys, cell_size, n))


def grid_cell_runs(coords: np.ndarray, cell_size: float, cells_per_side: int) -> np.ndarray:
    """Offsets ``(cells_per_side + 1,)`` of each fine cell's run in sorted coordinates along one axis.

    A coordinate's cell is ``floor(coord / cell_size)`` clamped to the lattice,
    as in ``raster.far_field_reference``: a sample on an edge between two cells belongs
    to the one with the larger index.  Compiled (a raster asks some forty times; numpy's five passes cost
    20 us a call); ``grid_cell_runs_reference`` is the plain form.
    """
    return _cell_runs(np.ascontiguousarray(coords, np.float64), float(cell_size), int(cells_per_side))


def grid_cell_runs_reference(coords: np.ndarray, cell_size: float, cells_per_side: int) -> np.ndarray:
    """``grid_cell_runs`` in numpy."""
    cells = np.clip(np.floor(coords / cell_size), 0, cells_per_side - 1).astype(np.int64)
    return np.searchsorted(cells, np.arange(cells_per_side + 1)).astype(np.int64)


@numba.njit(cache=True)
def _cell_runs(coords, cell_size, n):
    runs = np.full(n + 1, len(coords), np.int64)
    cell = 0  # the next cell whose run has not started
    for i in range(len(coords)):
        last = min(max(np.floor(coords[i] / cell_size), 0.0), n - 1.0)
        while cell <= last:
            runs[cell] = i
            cell += 1
    return runs


@numba.njit(cache=True)
def _non_decreasing(values):
    """Whether ``values`` are numbers (no NaN) in non-decreasing order."""
    for i in range(len(values)):
        if values[i] != values[i] or (i > 0 and values[i] < values[i - 1]):
            return False
    return True


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
    tables: tuple[np.ndarray, np.ndarray] | None = None,
    precision: str = "double",
    skip: np.ndarray | None = None,
    bounds: np.ndarray | None = None,
) -> np.ndarray:
    """``near_sum`` on the tensor grid ``ys x xs``, ``(len(ys), len(xs), channels)``: as many channels as ``flux``
    and ``jump`` have columns (3, or 4 with an alpha field's after the colour's).

    Works by rows of cells: in a row, the samples of three neighbouring cells
    against the segments of the middle one's column of three cells (gathered
    once), so every segment meets the samples of its 3x3 block in three visits,
    with a loop over the window's samples that vectorises.  Cells of at most
    ``ROW_SAMPLES`` samples a side would give that loop a few iterations: their
    lattices go to ``near_rows`` (float64 whatever ``precision``).  Threads take
    rows spread over the lattice (``rows.spread_rows``).

    Parameters
    ----------
    xs, ys : numpy.ndarray
        Sorted (non-decreasing) sample coordinates in document pixels.
    cells_per_side, cell_size, cell_start, p, q, flux, jump
        As for ``near_sum``: the lattice and the segments sorted by cell.
    out : numpy.ndarray, optional
        ``(len(ys), len(xs), channels)`` float64 C-contiguous; the near field is
        *added* to it (the far field, say) and it is returned.
    tables : tuple of numpy.ndarray, optional
        ``segment_sums.near_tables(p, q, flux, jump)``, when kept from an earlier call.
    precision : {"double", "single"}
        ``"single"``: a visit runs in float32 (``single``) where every sample of its window has an error bound
        (``single.error_bounds``) within ``single.SINGLE_BUDGET``, samples with a pair in doubt summed again
        in float64; the float32 field is then within that budget of the float64 one.
    skip : numpy.ndarray, optional
        ``(cells_per_side,) * 2`` bool: cells whose samples need no near field (``raster``: a layer hidden
        there); theirs get a part of it or none, the other samples all of it, as without ``skip``.  Lattices
        of at most ``ROW_SAMPLES`` samples a cell side sum every cell.
    bounds : numpy.ndarray, optional
        ``single.error_bounds`` of these segments, when kept from an earlier call.
    """
    if precision not in ("double", "single"):
        raise ValueError(f"unknown precision {precision!r}; use 'double' or 'single'")
    xs, ys, out = grid_arrays(xs, ys, out, np.shape(flux)[1])
    n = int(cells_per_side)
    if out.size == 0 or len(p) == 0:
        return out
    x_start = grid_cell_runs(xs, cell_size, n)
    y_start = grid_cell_runs(ys, cell_size, n)
    cell_start = np.asarray(cell_start, np.int64)
    table, weights = tables or near_tables(p, q, flux, jump)
    if max(np.diff(x_start).max(), np.diff(y_start).max()) <= ROW_SAMPLES:
        near_rows(xs, ys, x_start, y_start, n, cell_start, table, weights, out)
        return out
    capacity, most = _column_sizes(n, cell_start, x_start, y_start)
    single = np.zeros((n, n), np.bool_)
    if precision == "single":
        if bounds is None:
            bounds = error_bounds(n, cell_size, cell_start, flux, jump)
        single = _single_windows(np.ascontiguousarray(bounds, np.float64), SINGLE_BUDGET)
    if skip is not None and skip.shape != (n, n):
        raise ValueError(f"skip must have the shape {(n, n)}")
    _NEAR_GRID[out.shape[2]](xs, ys, x_start, y_start, n, cell_start, float(cell_size), table, weights, capacity,
                             most, single, bool(single.any()), skip_flags(skip), out)
    return out


_NO_SKIP = np.zeros((0, 0), np.bool_)


def skip_flags(skip: np.ndarray | None) -> np.ndarray:
    """A kernel's ``skip``: ``(n, n)`` bool, C-contiguous, or ``(0, 0)`` for none."""
    return _NO_SKIP if skip is None else np.ascontiguousarray(skip, np.bool_)
_NO_SCALAR = np.zeros(0)


@numba.njit(cache=True)
def _column_sizes(n, cell_start, x_start, y_start):
    """The most segments in a column of three cells and the most samples in a window of three (``near_row``)."""
    column, rows, window = 1, 0, 0
    for c in range(n):
        rows = max(rows, y_start[c + 1] - y_start[c])
        window = max(window, x_start[min(c + 2, n)] - x_start[max(c - 1, 0)])
        for cx in range(n):
            count = 0
            for cy in range(max(c - 1, 0), min(c + 2, n)):
                count += cell_start[cy * n + cx + 1] - cell_start[cy * n + cx]
            column = max(column, count)
    return column, max(1, rows * window)


@numba.njit(cache=True)
def _single_windows(bounds, budget):
    """``(n, n)`` bool: the cells whose row's window of three (``near_row``) has every ``bounds`` within ``budget``
    (beyond the lattice's edges counting as within)."""
    n = bounds.shape[0]
    single = np.zeros((n, n), np.bool_)
    for cy in range(n):
        for cx in range(n):
            single[cy, cx] = ((cx == 0 or bounds[cy, cx - 1] <= budget) and bounds[cy, cx] <= budget
                              and (cx == n - 1 or bounds[cy, cx + 1] <= budget))
    return single


# --- Far field (cell polynomials) on a tensor grid ----------------------------------------


@numba.njit(parallel=True, cache=True, fastmath=GRID_MATH, error_model="numpy")
def _far_grid(poly, scalar, degree, xs, ys, x_start, y_start, cell_size, skip, out, add):
    """Horner in eta, then in xi, up to ``degree`` per axis; the inner loops run over a cell's samples (they
    vectorise).  With ``scalar (3,)`` (not empty), one channel: each cell's polynomial of ``scalar . colour``.
    Cells where ``skip`` (``(n, n)``, or ``(0, 0)``: none) are left as they are."""
    n = poly.shape[0]
    spread = spread_rows(y_start)
    for t in numba.prange(len(spread)):
        cy = spread[t]
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
        mixed = np.empty((degree + 1, degree + 1))
        for cx in range(n):
            xa, xb = x_start[cx], x_start[cx + 1]
            cols = xb - xa
            if cols == 0 or (skip.shape[0] > 0 and skip[cy, cx]):
                continue
            for b in range(cols):
                xi[b] = xs[xa + b] / cell_size - (cx + 0.5)
            for c in range(out.shape[2]):
                coeffs = poly[cy, cx, c]
                if scalar.shape[0]:
                    for i in range(degree + 1):
                        for j in range(degree + 1):
                            mixed[i, j] = (scalar[0] * poly[cy, cx, 0, i, j] + scalar[1] * poly[cy, cx, 1, i, j]
                                           + scalar[2] * poly[cy, cx, 2, i, j])
                    coeffs = mixed
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
                    if add:
                        for b in range(cols):
                            out[ya + a, xa + b, c] += values[b]
                    else:
                        for b in range(cols):
                            out[ya + a, xa + b, c] = values[b]


def far_field_grid(poly: np.ndarray, xs: np.ndarray, ys: np.ndarray, cell_size: float,
                   order: int | None = None, out: np.ndarray | None = None,
                   scalar: np.ndarray | None = None, skip: np.ndarray | None = None) -> np.ndarray:
    """Cell polynomials on the tensor grid ``ys x xs``, ``(len(ys), len(xs), 3)``; with ``scalar (3,)``, those of
    the one channel ``scalar . colour`` (a mask's luminance: a third of the work), ``(len(ys), len(xs), 1)``.

    Compiled twin of ``raster.far_field_reference``.

    Parameters
    ----------
    poly : numpy.ndarray
        ``(n, n, 3, p + 1, p + 1)`` coefficients of ``xi^i eta^j``, ``(xi, eta)``
        the position in the cell relative to its centre, in cell sizes.
    xs, ys : numpy.ndarray
        Sorted (non-decreasing) sample coordinates in document pixels.
    cell_size : float
    order : int, optional
        Only the terms ``i, j <= order`` (all by default; a higher order adds nothing).
    out : numpy.ndarray, optional
        C-contiguous float64 of that shape: the polynomials are *added* to it.
    scalar : numpy.ndarray, optional
        ``(3,)``: the weights of the one channel.
    skip : numpy.ndarray, optional
        ``(n, n)`` bool: cells whose samples are left as they are (not needed).
    """
    fresh = out is None
    xs, ys, out = grid_arrays(xs, ys, out, 3 if scalar is None else 1)
    n, own = poly.shape[0], poly.shape[-1] - 1
    degree = own if order is None else min(int(order), own)
    if out.size:
        _far_grid(np.ascontiguousarray(poly, dtype=np.float64),
                  _NO_SCALAR if scalar is None else np.ascontiguousarray(scalar, np.float64), degree, xs, ys,
                  grid_cell_runs(xs, cell_size, n), grid_cell_runs(ys, cell_size, n), float(cell_size),
                  skip_flags(skip), out, not fresh)
    return out
