"""Compiled kernels of a build's passes over whole levels; ``passes`` drives them, ``lattice`` is the reference.

Expansions are held as real and imaginary planes.  A level whose cells are
mostly occupied keeps its multipoles as a *grid*, split by row and column
parity and zero-padded by ``GRID_PAD`` half-cells, ``(2, 2, n/2 + 2P, K, 3,
n/2 + 2P)``: the targets of one parity in one row then see each member of
their interaction lists at one fixed shift of one row of one grid, so M2L is
a sweep along contiguous rows (the *row sweep*).  A sparse level keeps only
its occupied cells, ``(cells, 3, K)``, with an index map padded by
``INDEX_PAD`` cells (-1 where empty), and each target gathers the occupied
members of its list.  Local expansions of a coarse level are plain planes
``(n, Q, 3, n)``: a row of children of one parity reads one row of parents.

The row sweeps take two multipole terms at a time (``_PAIR``): measured on
2 cores, one term per sweep is bound by the stores of the accumulated row,
four spill the matrix entries out of the registers.  Index arithmetic in the
sweeps is unsigned, so that numba emits no negative-index wraparound (which
keeps LLVM from vectorising).
"""

from __future__ import annotations

import numba
import numpy as np

from ..kernels.fastmath import FAST_MATH, INV_TWO_PI
from ..threads import one_thread

#: Half-cells of zeros around each parity grid: members of an interaction list are at most 2 away.
GRID_PAD = 2
#: Cells of -1 around a sparse level's index map: members of an interaction list are at most 3 away.
INDEX_PAD = 3
#: Multipole terms one row sweep reads (matrices are zero-padded to a multiple).
PAIR = 2
#: Columns of ``offset_table``: offset, source grid and its shift, multipole term pairs, highest local term.
DX, DY, GRID_Y, GRID_X, SHIFT_Y, SHIFT_X, PAIRS, LOCAL = range(8)
#: Which entries of a translation's matrix ``m[k, l]`` ``_add_row`` reads: all, ``l >= k`` or ``l <= k``.
FULL, UPPER, LOWER = 0, 1, 2
#: Cells (or pieces of work of about a cell's) below which a kernel's parallel loop runs on one thread: waking
#: the other costs more than such work, 4-8 ms (a scheduler tick or two) while another process holds a core.
PARALLEL_CELLS = 4096


def threads_for(cells: float, parallel_from: float = PARALLEL_CELLS):
    """Within the block, numba's parallel loops run on one thread when ``cells < parallel_from``."""
    return one_thread(cells < parallel_from)


@numba.njit(cache=True, fastmath=FAST_MATH, inline="always")
def _sweep(acc_re, acc_im, l, ch, row_re, row_im, k, column, count, t0r, t0i, t1r, t1i):
    """``acc[l, ch, :count] += t0 * row[k, ch, column:] + t1 * row[k + 1, ch, column:]`` (complex, as planes)."""
    start = np.uint64(column)
    for b in range(np.uint64(count)):
        c = start + b
        x0, y0 = row_re[k, ch, c], row_im[k, ch, c]
        x1, y1 = row_re[k + 1, ch, c], row_im[k + 1, ch, c]
        acc_re[l, ch, b] += t0r * x0 - t0i * y0 + t1r * x1 - t1i * y1
        acc_im[l, ch, b] += t0r * y0 + t0i * x0 + t1r * y1 + t1i * x1


@numba.njit(cache=True, fastmath=FAST_MATH, inline="always")
def _add_row(acc_re, acc_im, row_re, row_im, column, count, pairs, top, m_re, m_im, o, triangle=FULL):
    """``acc[l] += sum_k m[o, k, l] row[k]`` for ``l <= top``, ``k < 2 pairs``, over ``count`` columns from ``column``.

    ``triangle``: ``UPPER`` skips the ``l < k`` a matrix without them (M2M) would add as zeros, ``LOWER`` the
    ``l > k`` (L2L): half the work of those translations.
    """
    for pair in range(pairs):
        k = PAIR * pair
        first = k if triangle == UPPER else 0
        last = min(top, k + 1) if triangle == LOWER else top
        for ch in range(3):
            for l in range(first, last + 1):
                _sweep(acc_re, acc_im, l, ch, row_re, row_im, k, column, count,
                       m_re[o, k, l], m_im[o, k, l], m_re[o, k + 1, l], m_im[o, k + 1, l])


@numba.njit(cache=True, fastmath=FAST_MATH, inline="always")
def _gather(acc_re, acc_im, b, row, column, index, src_re, src_im, table, o0, o1, m_re, m_im, buf_re, buf_im):
    """``acc[:, :, b] +=`` M2L from the occupied members of the list of cell ``(row, column)`` (offsets ``o0:o1``).

    Summed in ``buf (3, terms)`` first: the innermost loop runs along the local terms of one matrix row.
    """
    hits = 0
    for o in range(o0, o1):
        s = index[row + INDEX_PAD + table[o, DY], column + INDEX_PAD + table[o, DX]]
        if s < 0:
            continue
        if hits == 0:
            buf_re[:] = 0.0
            buf_im[:] = 0.0
        hits += 1
        top = table[o, LOCAL] + 1
        for ch in range(3):
            for k in range(PAIR * table[o, PAIRS]):
                x, y = src_re[s, ch, k], src_im[s, ch, k]
                for l in range(top):
                    buf_re[ch, l] += m_re[o, k, l] * x - m_im[o, k, l] * y
                    buf_im[ch, l] += m_re[o, k, l] * y + m_im[o, k, l] * x
    if hits:
        for l in range(buf_re.shape[1]):
            for ch in range(3):
                acc_re[l, ch, b] += buf_re[ch, l]
                acc_im[l, ch, b] += buf_im[ch, l]


@numba.njit(cache=True, inline="always")
def _sources_near(index, row):
    """Whether a sparse level has sources within the reach of an interaction list of row ``row``."""
    for r in range(row, row + 2 * INDEX_PAD + 1):
        for c in range(index.shape[1]):
            if index[r, c] >= 0:
                return True
    return False


@numba.njit(cache=True, fastmath=FAST_MATH, inline="always")
def _write_fine(fine, base, change, centres, acc_re, acc_im, row, terms):
    """Row ``row`` of the fine level from ``acc (2, terms, 3, half)`` (its cells of column parity 0, then 1), in
    the order of memory: ``fine = acc`` or, with a ``base``, ``base + acc`` (``base`` past ``terms``) and
    ``change`` the largest part of ``acc``; ``centres`` (unless empty) the far field at each cell's centre."""
    added = base.size > 0
    centred = centres.size > 0
    for column in range(fine.shape[1]):
        px, b = column % 2, column // 2
        largest = 0.0
        for ch in range(3):
            for l in range(terms):
                x, y = acc_re[px, l, ch, b], acc_im[px, l, ch, b]
                if added:
                    fine[row, column, ch, l] = base[row, column, ch, l] + complex(x, y)
                    largest = max(largest, abs(x), abs(y))
                else:
                    fine[row, column, ch, l] = complex(x, y)
            if added:
                for l in range(terms, base.shape[3]):
                    fine[row, column, ch, l] = base[row, column, ch, l]
            if centred:
                centres[row, column, ch] = fine[row, column, ch, 0].real * INV_TWO_PI
        if added:
            change[row, column] = largest


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def level_local(size, parent_re, parent_im, l2l_re, l2l_im, grid_re, grid_im, src_re, src_im, index,
                table, starts, m2l_re, m2l_im, terms, coarse_re, coarse_im, fine, base, change, centres):
    """The local expansions of one level: L2L from the level above plus M2L, a row at a time (each column
    parity apart, then the row written whole).

    Parameters
    ----------
    size : int
        Cells per side of the level.
    parent_re, parent_im : numpy.ndarray
        ``(size / 2, Q', 3, size / 2)`` local expansions of the level above (empty at level 2).
    l2l_re, l2l_im : numpy.ndarray
        ``(4, Q', terms)`` L2L matrix of each child parity ``2 py + px``, padded to an even ``Q'``.
    grid_re, grid_im : numpy.ndarray
        The level's multipoles as a grid, or empty: the level is sparse.
    src_re, src_im, index : numpy.ndarray
        A sparse level's occupied cells' multipoles and its index map (empty when dense).
    table, starts : numpy.ndarray
        ``offset_table`` rows of each parity ``p`` at ``starts[p]:starts[p + 1]``.
    m2l_re, m2l_im : numpy.ndarray
        ``(rows, K, terms)`` M2L matrix of each row, truncated to its orders.
    terms : int
        Local terms kept.
    coarse_re, coarse_im : numpy.ndarray
        ``(size, terms, 3, size)`` output of a coarse level (empty at the fine level).
    fine : numpy.ndarray
        ``(size, size, 3, >= terms)`` complex output of the fine level (empty otherwise).
    base, change : numpy.ndarray
        Empty, or (an edit's change) ``base (size, size, 3, K)`` complex, ``K >= terms``, and ``change (size,
        size)``: ``fine`` (``K`` terms) is then ``base`` plus the level's expansions, and ``change`` their
        largest real or imaginary part per cell (``cells.largest_part``).
    centres : numpy.ndarray
        Empty, or ``(size, size, 3)``: the fine level's far field at each cell's centre, ``Re L_0 / 2 pi``
        (``Cells.centres``).
    """
    half = size // 2
    dense = grid_re.size > 0
    for task in numba.prange(2 * half):
        py, a = np.int64(task) // half, np.int64(task) % half
        row = 2 * a + py
        both_re = np.zeros((2, terms, 3, half))
        both_im = np.zeros((2, terms, 3, half))
        buf_re = np.empty((3, terms))
        buf_im = np.empty((3, terms))
        gathers = not dense and _sources_near(index, row)
        for px in range(2):
            parity = 2 * py + px
            acc_re, acc_im = both_re[px], both_im[px]
            if parent_re.size > 0:
                _add_row(acc_re, acc_im, parent_re[a], parent_im[a], 0, half, l2l_re.shape[1] // PAIR, terms - 1,
                         l2l_re, l2l_im, parity, LOWER)
            for o in range(starts[parity], starts[parity + 1]):
                if dense:
                    rows_re = grid_re[table[o, GRID_Y], table[o, GRID_X], a + GRID_PAD + table[o, SHIFT_Y]]
                    rows_im = grid_im[table[o, GRID_Y], table[o, GRID_X], a + GRID_PAD + table[o, SHIFT_Y]]
                    _add_row(acc_re, acc_im, rows_re, rows_im, GRID_PAD + table[o, SHIFT_X], half, table[o, PAIRS],
                             table[o, LOCAL], m2l_re, m2l_im, o)
            if gathers:
                for b in range(half):
                    _gather(acc_re, acc_im, b, row, 2 * b + px, index, src_re, src_im, table, starts[parity],
                            starts[parity + 1], m2l_re, m2l_im, buf_re, buf_im)
        if fine.size > 0:
            _write_fine(fine, base, change, centres, both_re, both_im, row, terms)
        else:
            for l in range(terms):
                for ch in range(3):
                    for column in range(size):
                        coarse_re[row, l, ch, column] = both_re[column % 2, l, ch, column // 2]
                        coarse_im[row, l, ch, column] = both_im[column % 2, l, ch, column // 2]


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def grid_m2m(child_re, child_im, m2m_re, m2m_im, parent_re, parent_im):
    """The multipoles of a dense level's parents, as their grid, from the children's grid (M2M row sweeps).

    ``m2m_re, m2m_im (4, K, K')``: M2M matrix of each child parity, from the children's ``K`` terms to the
    parents' ``K'``, zero-padded to even sizes.
    """
    size = child_re.shape[2] - 2 * GRID_PAD  # the parent level's cells per side
    terms = m2m_re.shape[2]
    for row in numba.prange(size):
        acc_re = np.zeros((terms, 3, size))
        acc_im = np.zeros((terms, 3, size))
        for parity in range(4):
            _add_row(acc_re, acc_im, child_re[parity // 2, parity % 2, row + GRID_PAD],
                     child_im[parity // 2, parity % 2, row + GRID_PAD], GRID_PAD, size, m2m_re.shape[1] // PAIR,
                     terms - 1, m2m_re, m2m_im, parity, UPPER)
        for column in range(size):
            for l in range(terms):
                for ch in range(3):
                    parent_re[row % 2, column % 2, row // 2 + GRID_PAD, l, ch,
                              column // 2 + GRID_PAD] = acc_re[l, ch, column]
                    parent_im[row % 2, column % 2, row // 2 + GRID_PAD, l, ch,
                              column // 2 + GRID_PAD] = acc_im[l, ch, column]


@numba.njit(parallel=True, cache=True, fastmath=FAST_MATH)
def compact_m2m(size, parents, child_index, child_re, child_im, m2m_re, m2m_im, out_re, out_im):
    """The multipoles ``out (len(parents), 3, K')`` of the occupied ``parents`` (flat, level ``size / 2`` wide)
    of a sparse level's occupied children (``child_index``, ``child_re``, ``child_im`` as for ``level_local``).

    ``m2m_re, m2m_im (4, K', K)``: the M2M matrix of each child parity *transposed*, so that each parent term is
    a dot product along a contiguous row (half the time of adding each child term into the parent's row).
    """
    half = size // 2
    terms, child_terms = m2m_re.shape[1], m2m_re.shape[2]
    for p in numba.prange(len(parents)):
        row, column = parents[p] // half, parents[p] % half
        for parity in range(4):
            s = child_index[2 * row + parity // 2 + INDEX_PAD, 2 * column + parity % 2 + INDEX_PAD]
            if s < 0:
                continue
            for ch in range(3):
                x, y = child_re[s, ch], child_im[s, ch]
                for l in range(terms):
                    total_re = 0.0
                    total_im = 0.0
                    for k in range(min(l + 1, child_terms)):  # M2M is upper triangular
                        a, b = m2m_re[parity, l, k], m2m_im[parity, l, k]
                        total_re += a * x[k] - b * y[k]
                        total_im += a * y[k] + b * x[k]
                    out_re[p, ch, l] += total_re
                    out_im[p, ch, l] += total_im


@numba.njit(parallel=True, cache=True)
def fill_grid(position, values_re, values_im, grid_re, grid_im):
    """Put the multipoles ``values (cells, 3, >= K)`` (planes) of a level into its grid ``(2, 2, s, K, 3, s)``.

    ``position (size, size)``: the row of ``values`` of each cell, -1 where it is empty (left zero).  The
    writes run along the grid's rows.
    """
    half = position.shape[0] // 2
    terms = grid_re.shape[3]
    for task in numba.prange(4 * half):
        parity, gy = task // half, task % half
        py, px = parity // 2, parity % 2
        for k in range(terms):
            for ch in range(3):
                for gx in range(half):
                    s = position[2 * gy + py, 2 * gx + px]
                    if s >= 0:
                        grid_re[py, px, gy + GRID_PAD, k, ch, gx + GRID_PAD] = values_re[s, ch, k]
                        grid_im[py, px, gy + GRID_PAD, k, ch, gx + GRID_PAD] = values_im[s, ch, k]


@numba.njit(parallel=True, cache=True)
def fill_grid_complex(position, values, grid_re, grid_im):
    """``fill_grid`` from complex ``values (cells, 3, >= K)``: the fine multipoles as P2M made them."""
    half = position.shape[0] // 2
    terms = grid_re.shape[3]
    for task in numba.prange(4 * half):
        parity, gy = task // half, task % half
        py, px = parity // 2, parity % 2
        for k in range(min(terms, values.shape[2])):
            for ch in range(3):
                for gx in range(half):
                    s = position[2 * gy + py, 2 * gx + px]
                    if s >= 0:
                        grid_re[py, px, gy + GRID_PAD, k, ch, gx + GRID_PAD] = values[s, ch, k].real
                        grid_im[py, px, gy + GRID_PAD, k, ch, gx + GRID_PAD] = values[s, ch, k].imag
