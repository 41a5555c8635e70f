"""The far field of an FMR on a tensor grid of samples: each sample's cell local expansion, by Horner (compiled).

A sample in fine cell ``(cy, cx)`` at ``w = xi + i eta`` (its offset from
the cell centre in cell sizes) takes ``(1/2pi) Re sum_{l <= d} L_l w^l``
of that cell's scaled local expansion ``L`` (docs/design.md section 3), written
straight into the image; ``d`` is the degree the cell's samples need, by their
largest distance from its centre (``cell_degree``: at most ``order``, the
constant term alone at the centre).  Threads take rows of cells; each cell's
samples are evaluated by Horner's rule in ``w``, the channels side by side (three, or four: a translucent
layer's image with its alpha field, ``raster``),
or, in cells of many samples, all at once with the powers of ``w`` (a loop
over the samples that vectorises).  Those powers depend only on where the samples lie in their cell: a
row's cells read the table of them the last cell made (``powers_table``) while their samples lie where its
did, as every cell's do but at the edges in a raster in step with the lattice.  The cost is pixels x order
plus one read of the cells' coefficients.  Cells of few samples read them as they are, with no table: at
level 10 (one sample a cell at 1024^2) a table made the far field 1.4x slower.

``local_field_reference`` is the plain numpy form; the tests compare them.
"""

from __future__ import annotations

import numba
import numpy as np

from .fastmath import FAST_MATH, INV_TWO_PI
from .grid import grid_arrays, grid_cell_runs
from .rows import spread_rows

_NO_CENTRES = np.zeros((0, 0, 3))
_NO_COUNTS = np.zeros(0, np.int64)
#: The kernels' ``fourth`` expansions of three channels: none.
NO_FOURTH = np.zeros((0, 0, 1, 1), np.complex128)

#: The largest distance from its cell's centre a sample inside the cell can have (a corner's), in cell sizes.
CORNER_RADIUS = np.sqrt(0.5)
#: Cells of at least this many samples evaluate them all at once, samples innermost (a vector loop over the
#: powers of ``w``); smaller ones sample by sample by Horner's rule.  Measured at 1024^2, levels 5-8: 8 -> 16 ms
#: at 8 x 8 samples a cell, Horner faster at 2 x 2.
FLAT = 16


def local_field_reference(local: np.ndarray, order: int, xs: np.ndarray, ys: np.ndarray,
                          cell_size: float, degrees: np.ndarray | None = None) -> np.ndarray:
    """``(1/2pi) Re sum_{l <= d} L_l w^l`` of each sample's cell on the grid ``ys x xs``, ``(len(ys), len(xs), 3)``,
    ``d`` the cell's degree as ``local_field_grid`` chooses it.

    Plain numpy (the far field alone; ``local_field_grid`` is the compiled twin); a sample's cell is
    ``floor(coord / cell_size)`` clamped to the lattice, as in ``grid.grid_cell_runs``; ``w`` is its offset from
    the cell centre in cell sizes.
    """
    n = local.shape[0]
    column = np.clip(np.floor(xs / cell_size).astype(np.int64), 0, n - 1)
    row = np.clip(np.floor(ys / cell_size).astype(np.int64), 0, n - 1)
    xi, eta = xs / cell_size - (column + 0.5), ys / cell_size - (row + 0.5)
    across, down = np.zeros(n), np.zeros(n)
    np.maximum.at(across, column, xi**2)
    np.maximum.at(down, row, eta**2)
    radius = np.sqrt(down[:, None] + across[None, :])  # (cells, cells): each cell's samples' largest |w|
    degrees = np.full(1, order) if degrees is None else np.asarray(degrees)
    bins = np.maximum(np.ceil(radius / CORNER_RADIUS * len(degrees)).astype(np.int64) - 1, 0)
    degree = np.where(radius > CORNER_RADIUS, order, np.minimum(order, degrees[np.minimum(bins, len(degrees) - 1)]))
    degree[radius == 0] = 0
    w = xi[None, :] + 1j * eta[:, None]
    kept = np.arange(order + 1) <= degree[row[:, None], column[None, :], None, None]
    coeffs = np.where(kept, local[row[:, None], column[None, :], :, : order + 1], 0)  # (ys, xs, 3, order + 1)
    return (coeffs * w[..., None, None] ** np.arange(order + 1)).sum(-1).real / (2 * np.pi)


def _powers_sum(channels):
    """``by_powers`` of ``channels`` (3 or 4), the fourth written out beside the three (``blocks.samples_loop``)."""
    four = channels == 4

    @numba.njit(inline="always", fastmath=FAST_MATH, error_model="numpy")
    def by_powers(coeffs, order, count, xi, eta, scale, scratch):
        re, im, a0, a1, a2 = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
        a3 = scratch[5] if four else scratch[4]
        for i in range(count):
            re[i], im[i] = 1.0, 0.0
            a0[i], a1[i], a2[i] = 0.0, 0.0, 0.0
            if four:
                a3[i] = 0.0
        for l in range(order + 1):
            r0, r1, r2 = coeffs[0, l].real * scale, coeffs[1, l].real * scale, coeffs[2, l].real * scale
            i0, i1, i2 = coeffs[0, l].imag * scale, coeffs[1, l].imag * scale, coeffs[2, l].imag * scale
            r3, i3 = (coeffs[3, l].real * scale, coeffs[3, l].imag * scale) if four else (0.0, 0.0)
            for i in range(count):
                p, q = re[i], im[i]
                a0[i] += r0 * p - i0 * q
                a1[i] += r1 * p - i1 * q
                a2[i] += r2 * p - i2 * q
                if four:
                    a3[i] += r3 * p - i3 * q
                re[i], im[i] = p * xi[i] - q * eta[i], p * eta[i] + q * xi[i]

    return by_powers


#: ``scratch[2:2 + channels, :count]`` = the channels of ``scale Re sum_l coeffs[c, l] w^l`` at ``w = xi + i eta``,
#: ``coeffs (channels, > order)``: ``by_powers`` of three channels, ``by_powers4`` of four.  Samples innermost (the
#: loop vectorises); ``scratch (>= 2 + channels, >= count)``, its rows 0 and 1 the powers of ``w``.
by_powers, by_powers4 = _powers_sum(3), _powers_sum(4)


@numba.njit(inline="always", fastmath=FAST_MATH, error_model="numpy")
def powers_table(order, count, xi, eta, table):
    """``table[2 l, :count]`` and ``table[2 l + 1, :count]``: the real and imaginary parts of ``w^l``, ``l <= order``,
    at ``w = xi + i eta``, by ``by_powers``' recurrence."""
    for i in range(count):
        table[0, i], table[1, i] = 1.0, 0.0
    for l in range(order):
        re, im, next_re, next_im = table[2 * l], table[2 * l + 1], table[2 * l + 2], table[2 * l + 3]
        for i in range(count):
            next_re[i], next_im[i] = re[i] * xi[i] - im[i] * eta[i], re[i] * eta[i] + im[i] * xi[i]


def _table_sum(channels):
    """``from_table`` of ``channels`` (3 or 4), the fourth written out beside the three (``blocks.samples_loop``)."""
    four = channels == 4

    @numba.njit(inline="always", fastmath=FAST_MATH, error_model="numpy")
    def from_table(coeffs, order, count, table, scale, scratch):
        a0, a1, a2 = scratch[2], scratch[3], scratch[4]
        a3 = scratch[5] if four else scratch[4]
        for l in range(order + 1):
            r0, r1, r2 = coeffs[0, l].real * scale, coeffs[1, l].real * scale, coeffs[2, l].real * scale
            i0, i1, i2 = coeffs[0, l].imag * scale, coeffs[1, l].imag * scale, coeffs[2, l].imag * scale
            r3, i3 = (coeffs[3, l].real * scale, coeffs[3, l].imag * scale) if four else (0.0, 0.0)
            re, im = table[2 * l], table[2 * l + 1]
            if l == 0:
                for i in range(count):
                    a0[i], a1[i], a2[i] = r0 * re[i] - i0 * im[i], r1 * re[i] - i1 * im[i], r2 * re[i] - i2 * im[i]
                    if four:
                        a3[i] = r3 * re[i] - i3 * im[i]
                continue
            for i in range(count):
                a0[i] += r0 * re[i] - i0 * im[i]
                a1[i] += r1 * re[i] - i1 * im[i]
                a2[i] += r2 * re[i] - i2 * im[i]
                if four:
                    a3[i] += r3 * re[i] - i3 * im[i]

    return from_table


#: ``by_powers`` from the powers of ``w`` in a ``powers_table`` (``table (2 (order + 1), >= count)``), made once for
#: every cell whose samples lie where the first one's do: ``from_table`` of three channels, ``from_table4`` of four.
from_table, from_table4 = _table_sum(3), _table_sum(4)


def _horner(channels):
    """``Re sum_l coeffs[c, l] w^l`` at one ``w = xi + i eta`` by Horner's rule, the ``channels`` (3 or 4) side by
    side: four values (the fourth 0 of three channels)."""
    four = channels == 4

    @numba.njit(inline="always", fastmath=FAST_MATH, error_model="numpy")
    def by_horner(coeffs, order, xi, eta):
        r0, i0 = coeffs[0, order].real, coeffs[0, order].imag
        r1, i1 = coeffs[1, order].real, coeffs[1, order].imag
        r2, i2 = coeffs[2, order].real, coeffs[2, order].imag
        r3, i3 = (coeffs[3, order].real, coeffs[3, order].imag) if four else (0.0, 0.0)
        for l in range(order - 1, -1, -1):
            a0, a1, a2 = coeffs[0, l], coeffs[1, l], coeffs[2, l]
            r0, i0 = r0 * xi - i0 * eta + a0.real, r0 * eta + i0 * xi + a0.imag
            r1, i1 = r1 * xi - i1 * eta + a1.real, r1 * eta + i1 * xi + a1.imag
            r2, i2 = r2 * xi - i2 * eta + a2.real, r2 * eta + i2 * xi + a2.imag
            if four:
                a3 = coeffs[3, l]
                r3, i3 = r3 * xi - i3 * eta + a3.real, r3 * eta + i3 * xi + a3.imag
        return r0, r1, r2, r3

    return by_horner


_by_horner3, _by_horner4 = _horner(3), _horner(4)

@numba.njit(cache=True)
def _largest_offsets(coordinates, start, inv):
    out = np.zeros(len(start) - 1)
    for c in range(len(start) - 1):
        for i in range(start[c], start[c + 1]):
            out[c] = max(out[c], (coordinates[i] * inv - (c + 0.5)) ** 2)
    return out


def largest_offsets(coordinates: np.ndarray, cell_size: float, cells: int) -> np.ndarray:
    """Per cell along one axis (of ``cells``), the largest squared offset of the sorted sample ``coordinates`` in
    it from its centre, in cell sizes (0 where it has none).  A cell's samples lie within the square root of its
    column's plus its row's of its centre: what ``cell_degree`` reads."""
    coordinates = np.ascontiguousarray(coordinates, np.float64)
    return _largest_offsets(coordinates, grid_cell_runs(coordinates, cell_size, cells), 1.0 / cell_size)


@numba.njit(cache=True, inline="always")
def cell_degree(order, degrees, radius2):
    """The degree of a cell whose samples lie within ``sqrt(radius2)`` of its centre: ``degrees``' bin of that
    radius (bins of ``CORNER_RADIUS / len(degrees)``), 0 when they all lie on it (exactly: only the constant
    term is not multiplied by 0), ``order`` beyond the corner radius."""
    if radius2 == 0.0:
        return 0
    position = np.sqrt(radius2) / CORNER_RADIUS * len(degrees)
    if position > len(degrees):
        return order
    return min(order, degrees[max(int(np.ceil(position)) - 1, 0)])


def _local_kernel(channels):
    """``local_grid`` of ``channels`` (3 or 4), a compiled kernel each (as ``grid._near_grid_of``)."""
    four = channels == 4

    @numba.njit(parallel=True, cache=True, fastmath=FAST_MATH, error_model="numpy")
    def local_grid(local, fourth, centres, fourth_centres, order, degrees, across, down, xs, ys, x_start, y_start,
                   cell_size, skip, skipping, zero_skipped, out, tables_made):
        """Overwrite ``out``'s samples with their cell's expansion, except in cells where ``skipping and skip`` (with
        ``zero_skipped``, 0 there); cells of degree 0 read ``centres`` unless it is empty.  Of four channels, the
        fourth is ``fourth``'s first (and ``fourth_centres``').  ``tables_made[cy]``, unless it is empty, counts
        the powers tables row ``cy`` made."""
        n = local.shape[0]
        centred = centres.shape[0] > 0
        inv = 1.0 / cell_size
        widest = 0
        for cx in range(n):
            widest = max(widest, x_start[cx + 1] - x_start[cx])
        spread = spread_rows(y_start)
        for t in numba.prange(len(spread)):
            cy = spread[t]
            ya, rows = y_start[cy], y_start[cy + 1] - y_start[cy]
            if rows == 0:
                continue
            coeffs = np.empty((channels, order + 1), np.complex128)
            flat = rows * widest if rows * widest >= FLAT else 0
            scratch = np.empty((4 + channels, flat))
            # the powers of w at the samples of the last cell that made them: the samples' columns' offsets from the
            # centre (its rows' are the row's), their count and the degree; a cell whose samples lie where its did
            # (a raster in step with the lattice: every cell but at the edges) reads them as they are
            table, table_xi = np.empty((2 * (order + 1), flat)), np.empty(widest)
            table_width, table_degree = 0, -1
            for cx in range(n):
                xa, width = x_start[cx], x_start[cx + 1] - x_start[cx]
                if width == 0:
                    continue
                if skipping and skip[cy, cx]:
                    if zero_skipped:
                        out[ya : ya + rows, xa : xa + width] = 0.0
                    continue
                degree = cell_degree(order, degrees, across[cx] + down[cy])
                if degree == 0 and centred:  # one contiguous read, not three terms 144 bytes apart
                    for a in range(rows):
                        for b in range(xa, xa + width):
                            for c in range(3):
                                out[ya + a, b, c] = centres[cy, cx, c]
                            if four:
                                out[ya + a, b, 3] = fourth_centres[cy, cx, 0]
                    continue
                if four:  # the four channels' coefficients side by side
                    for l in range(degree + 1):
                        for c in range(3):
                            coeffs[c, l] = local[cy, cx, c, l]
                        coeffs[3, l] = fourth[cy, cx, 0, l]
                if rows * width < FLAT:  # from the coefficients as they are: a copy would cost as much again
                    for a in range(rows):
                        eta = ys[ya + a] * inv - (cy + 0.5)
                        for b in range(xa, xa + width):
                            xi = xs[b] * inv - (cx + 0.5)
                            if four:
                                r0, r1, r2, r3 = _by_horner4(coeffs, degree, xi, eta)
                            else:
                                r0, r1, r2, r3 = _by_horner3(local[cy, cx], degree, xi, eta)
                            out[ya + a, b, 0], out[ya + a, b, 1] = r0 * INV_TWO_PI, r1 * INV_TWO_PI
                            out[ya + a, b, 2] = r2 * INV_TWO_PI
                            if four:
                                out[ya + a, b, 3] = r3 * INV_TWO_PI
                    continue
                if not four:
                    for c in range(3):
                        for l in range(degree + 1):
                            coeffs[c, l] = local[cy, cx, c, l]
                same = width == table_width and degree <= table_degree
                for b in range(width if same else 0):
                    if xs[xa + b] * inv - (cx + 0.5) != table_xi[b]:
                        same = False
                        break
                if not same:
                    xi, eta = scratch[2 + channels], scratch[3 + channels]
                    for a in range(rows):
                        for b in range(width):
                            xi[a * width + b] = xs[xa + b] * inv - (cx + 0.5)
                            eta[a * width + b] = ys[ya + a] * inv - (cy + 0.5)
                    powers_table(degree, rows * width, xi, eta, table)
                    if tables_made.shape[0]:
                        tables_made[cy] += 1
                    table_xi[:width] = xi[:width]
                    table_width, table_degree = width, degree
                if four:
                    from_table4(coeffs, degree, rows * width, table, INV_TWO_PI, scratch)
                else:
                    from_table(coeffs, degree, rows * width, table, INV_TWO_PI, scratch)
                for a in range(rows):
                    for b in range(width):
                        i = a * width + b
                        for c in range(channels):
                            out[ya + a, xa + b, c] = scratch[2 + c, i]

    return local_grid


#: The far field's kernel of each count of channels.
_LOCAL_GRID = {channels: _local_kernel(channels) for channels in (3, 4)}


def local_field_grid(local: np.ndarray, order: int, xs: np.ndarray, ys: np.ndarray, cell_size: float,
                     out: np.ndarray | None = None, skip: np.ndarray | None = None,
                     degrees: np.ndarray | None = None, offsets: tuple[np.ndarray, np.ndarray] | None = None,
                     centres: np.ndarray | None = None, zero_skipped: bool = False,
                     fourth: tuple[np.ndarray, np.ndarray | None] | None = None,
                     tables_made: np.ndarray | None = None) -> np.ndarray:
    """``(1/2pi) Re sum_{l <= d} L_l w^l`` of each sample's cell on the grid ``ys x xs``, ``(len(ys), len(xs),
    channels)``, ``d`` the cell's degree (``cell_degree``: at most ``order``): 3 channels, or 4 with ``fourth``.

    Compiled twin of ``local_field_reference``.

    Parameters
    ----------
    local : numpy.ndarray
        ``(n, n, 3, > order)`` complex scaled local expansions of the fine cells.
    order : int
        Highest term evaluated.
    xs, ys : numpy.ndarray
        Sorted (non-decreasing) sample coordinates in document pixels; a sample's
        cell is as in ``grid.grid_cell_runs``.
    cell_size : float
        Fine cell size in pixels.
    out : numpy.ndarray, optional
        C-contiguous float64 ``(len(ys), len(xs), channels)``, *overwritten* (but in
        skipped cells) and returned; zeros when missing.
    skip : numpy.ndarray, optional
        ``(n, n)`` bool: cells whose samples are left as they are in ``out`` (``zero_skipped``: made 0).
    degrees : numpy.ndarray, optional
        The degree of a cell by its samples' largest distance from its centre, in bins up to ``CORNER_RADIUS``
        (``fmm.orders.sample_degrees``); by default ``order`` wherever the samples are off the centre.
    offsets : tuple of numpy.ndarray, optional
        ``largest_offsets`` of the columns and rows of cells, when the grid is a band of a larger one (whose
        cells' degrees must not depend on the band); by default of ``xs`` and ``ys``.
    centres : numpy.ndarray, optional
        ``(n, n, 3)`` float64 ``Re L_0 / 2pi`` of each cell (``Representation.centre_values``): what cells of
        degree 0 read instead of ``local``, the same values from one contiguous row (at level 10, one sample a
        cell at 1024^2, this far field went 12.5 -> 1.2 ms).
    fourth : tuple of numpy.ndarray, optional
        ``(local, centres)`` of another field of the lattice (a translucent layer's alpha field): the first
        channel of each is evaluated as a fourth channel (``centres`` wanted when ``centres`` is given).  Its
        expansions are read where they are, not joined to ``local`` (a copy the size of the expansions).
    tables_made : numpy.ndarray, optional
        ``(n,)`` int64: each row of cells' count of the powers of ``w`` it made is added to it (the tests').
    """
    if not 0 <= order < local.shape[-1]:
        raise ValueError(f"order must be between 0 and {local.shape[-1] - 1}")
    # a writeable copy (a read-only array would compile the kernel anew)
    degrees = np.full(1, order, np.int64) if degrees is None else np.array(degrees, np.int64)
    n, channels = local.shape[0], 3 if fourth is None else 4
    fourth_local, fourth_centres = (NO_FOURTH, None) if fourth is None else fourth
    xs, ys, out = grid_arrays(xs, ys, out, channels)
    if skip is not None and skip.shape != (n, n):
        raise ValueError(f"skip must have the shape {(n, n)}")
    for values in (centres, fourth_centres):
        if values is not None and (values.shape[:2] != (n, n) or values.ndim != 3 or values.dtype != np.float64):
            raise ValueError(f"centres must be float64 of the shape {(n, n, 3)}")
    if fourth is not None and (fourth_local.shape[:2] != (n, n) or fourth_local.shape[-1] <= order
                               or (centres is None) != (fourth_centres is None)):
        raise ValueError("the fourth channel's expansions (and centres) must match the others'")
    if out.size == 0:
        return out
    flags = np.zeros((1, 1), np.bool_) if skip is None else np.ascontiguousarray(skip, np.bool_)
    across, down = offsets or (largest_offsets(xs, cell_size, n), largest_offsets(ys, cell_size, n))
    _LOCAL_GRID[channels](np.asarray(local, np.complex128), np.asarray(fourth_local, np.complex128),
                          _NO_CENTRES if centres is None else np.ascontiguousarray(centres),
                          _NO_CENTRES if fourth_centres is None else np.ascontiguousarray(fourth_centres),
                          int(order), degrees, across, down, xs, ys, grid_cell_runs(xs, cell_size, n),
                          grid_cell_runs(ys, cell_size, n), float(cell_size), flags, skip is not None,
                          bool(zero_skipped), out, _NO_COUNTS if tables_made is None else tables_made)
    return out
