"""The downward pass from a few occupied cells to a set of wanted cells.

The FMR is linear in its sources, so the local expansions of any set of
sources are their downward pass alone: a change of some cells' multipoles
(``delta_local``, on the build's compiled passes: every cell's local
expansion changes) or a clone layer's segments, which fill a part of the
lattice and matter only inside the clone's region (``pass_levels`` of the
wanted cells, their ``interactions``, then ``cascade``; ``sparse_local``
does all three).
Sources are a list of fine cells with their multipoles; M2M carries them up
to their parents only.  Targets are the wanted fine cells and their
ancestors: each gathers M2L from the occupied members of its interaction
list (a compiled loop, parallel over targets) and L2L from its parent.
Every other local expansion is left zero.

M2L goes through the factorisation of its scaled matrix (``m2l_matrix``)
``T[k, l] = d^-l P[k, l] (-1)^k d^-k``, ``P[k, l] = binom(l + k - 1, k - 1)``:
two complex diagonal scalings around one real Pascal matrix, half the
multiplications of the complex matrix; ``k = 0`` (the logarithm) is added
apart.  ``lattice.downward_pass`` is the reference.
"""

from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np
from scipy.special import comb

from .expansions import l2l_matrix, m2m_matrix
from .lattice import Lattice, child_offset, coarser_multipoles, distinct_cells, downward_pass, offset_parities, times
from .orders import PassOrders, uniform_orders
from .passes import downward, level_sources

#: Targets per task of the compiled M2L loop.
_CHUNK = 16


def _planes(values: np.ndarray) -> np.ndarray:
    """Complex ``(..., n)`` as real ``(..., 2, n)``: the real parts, then the imaginary parts."""
    return np.ascontiguousarray(np.stack([values.real, values.imag], axis=-2))


@lru_cache(maxsize=64)
def _m2l_tables(order: int, log_size: float) -> tuple[np.ndarray, ...]:
    """The factors of ``m2l_matrix`` for every offset of ``offset_parities``, at one level (``ln r = log_size``).

    ``pre (k, 2, P + 1)`` = ``(-1)^k d^-k`` and ``post`` = ``d^-l`` as planes, the real Pascal matrix
    ``P[k, l]`` transposed, ``(P + 1, P + 1)``, and ``log (k, 2)`` = ``ln(-d) + ln r``.  Row 0 of ``P``
    carries the logarithm's terms ``-a_0 / (l d^l)`` (``pre`` 1 there); its ``l = 0`` term, ``a_0 ln(-d r)``,
    is added apart.
    """
    offsets = offset_parities()[0]
    d = (offsets[:, 0] + 1j * offsets[:, 1])[:, None]
    k = np.arange(order + 1)
    pascal = np.array([[comb(l + source - 1, source - 1, exact=True) for l in k] for source in k], dtype=np.float64)
    pascal[0] = np.concatenate([[0.0], -1.0 / k[1:]])
    pre = (-1.0) ** k / d**k
    pre[:, 0] = 1.0
    log = np.log(-d[:, 0]) + log_size
    return (_planes(pre), np.ascontiguousarray(pascal.T), _planes(d ** (-k.astype(float))),
            np.stack([log.real, log.imag], axis=1))


@numba.njit(cache=True, fastmath=True, inline="always")
def _scaled_pascal(ar, ai, pre, pascal, post, multipole_terms, local_terms, out_r, out_i, br, bi):
    """``out += post * (P^T (pre * a))`` over the first ``multipole_terms`` of ``a`` and ``local_terms`` of ``out``:
    complex vectors as planes ``(re, im)``, ``P`` as its transpose."""
    for k in range(multipole_terms):
        br[k] = ar[k] * pre[0, k] - ai[k] * pre[1, k]
        bi[k] = ar[k] * pre[1, k] + ai[k] * pre[0, k]
    for l in range(local_terms):
        sr = 0.0
        si = 0.0
        row = pascal[l]
        for k in range(multipole_terms):
            sr += row[k] * br[k]
            si += row[k] * bi[k]
        out_r[l] += sr * post[0, l] - si * post[1, l]
        out_i[l] += sr * post[1, l] + si * post[0, l]


@numba.njit(parallel=True, cache=True, fastmath=True)
def _gathered_m2l(size, targets, source_index, moments, offsets, masks, terms_of, pre, pascal, post, log, out):
    """``out[t] +=`` M2L from every source in target ``t``'s interaction list.

    ``moments`` as planes ``(sources, channels, 2, P + 1)``, ``out`` complex ``(targets, channels, Q + 1)``,
    ``terms_of (offsets, 2)`` the multipole and local terms each offset's translation keeps (``Q + 1`` at most),
    ``pascal`` transposed.
    """
    channels, terms = out.shape[1], moments.shape[3]
    count = targets.shape[0]
    for chunk in numba.prange((count + _CHUNK - 1) // _CHUNK):
        br, bi = np.empty(terms), np.empty(terms)
        sums = np.empty((channels, 2, out.shape[2]))
        for t in range(chunk * _CHUNK, min(count, (chunk + 1) * _CHUNK)):
            row, column = divmod(targets[t], size)
            sums[:] = 0.0
            for o in range(offsets.shape[0]):
                sr, sc = row + offsets[o, 1], column + offsets[o, 0]
                if not masks[o, row % 2, column % 2] or sr < 0 or sr >= size or sc < 0 or sc >= size:
                    continue
                s = source_index[sr * size + sc]
                if s < 0:
                    continue
                for channel in range(channels):
                    ar, ai = moments[s, channel, 0], moments[s, channel, 1]
                    _scaled_pascal(ar, ai, pre[o], pascal, post[o], terms_of[o, 0], terms_of[o, 1], sums[channel, 0],
                                   sums[channel, 1], br, bi)
                    sums[channel, 0, 0] += ar[0] * log[o, 0] - ai[0] * log[o, 1]
                    sums[channel, 1, 0] += ar[0] * log[o, 1] + ai[0] * log[o, 0]
            for channel in range(channels):
                for l in range(out.shape[2]):
                    out[t, channel, l] += complex(sums[channel, 0, l], sums[channel, 1, l])


class _Level:
    """The cells of one level a pass visits, in blocks of one parity each (their L2L matrix): their rows and parents."""

    def __init__(self, cells: np.ndarray, size: int) -> None:
        rows, columns = np.divmod(cells, size)
        parity = 2 * (rows % 2) + columns % 2
        order = np.argsort(parity, kind="stable")
        self.size, self.cells = size, cells[order]
        self.bounds = np.searchsorted(parity[order], np.arange(5))
        self.row_of = np.full(size * size, -1, np.int64)
        self.row_of[self.cells] = np.arange(len(cells))
        self.parents = (rows[order] // 2) * (size // 2) + columns[order] // 2  # flat in the level above

    def blocks(self):
        """``(start, stop, px, py)`` of each parity's block."""
        for q in range(4):
            yield self.bounds[q], self.bounds[q + 1], q % 2, q // 2


def _upward(cells: np.ndarray, moments: np.ndarray, lattice: Lattice, order: int) -> list:
    """``(level, multipoles)`` of the source cells at every level ``2..L``: the fine ones, then their parents (M2M)."""
    sources = [None] * (lattice.levels + 1)
    level = _Level(np.asarray(cells, np.int64), lattice.cells_per_side)
    sources[lattice.levels] = level, np.take(np.asarray(moments, complex), np.argsort(level.row_of[cells]), axis=0)
    for depth in range(lattice.levels, 2, -1):
        level, multipoles = sources[depth]
        parents, slot = distinct_cells(level.parents, (level.size // 2) ** 2)
        above = np.zeros((len(parents),) + multipoles.shape[1:], complex)
        for start, stop, px, py in level.blocks():  # one child per parent in a block: no repeated slots
            above[slot[start:stop]] += times(multipoles[start:stop], m2m_matrix(child_offset(px, py), order))
        parent_level = _Level(parents, 2 ** (depth - 1))
        sources[depth - 1] = parent_level, np.take(above, np.argsort(parent_level.row_of[parents]), axis=0)
    return sources


def pass_levels(wanted: np.ndarray | None, lattice: Lattice) -> list[_Level | None]:
    """The cells a pass visits at each level ``2..L``: the ``wanted`` fine cells (bool ``(2^L, 2^L)``; None: all)
    and their ancestors."""
    levels: list[_Level | None] = [None] * (lattice.levels + 1)
    n = lattice.cells_per_side
    cells = np.arange(n * n) if wanted is None else np.flatnonzero(wanted)
    for depth in range(lattice.levels, 1, -1):
        levels[depth] = _Level(cells, 2**depth)
        cells = distinct_cells(levels[depth].parents, 4 ** (depth - 1))[0]
    return levels


def interactions(cells: np.ndarray, moments: np.ndarray, lattice: Lattice, order: int,
                 levels: list[_Level | None], orders: PassOrders | None = None) -> list[np.ndarray | None]:
    """The M2L part of a downward pass: at each level, what the interaction lists give ``levels``' cells.

    Parameters
    ----------
    cells : numpy.ndarray
        Flat indices ``row * 2^L + column`` of the fine cells holding sources, distinct.
    moments : numpy.ndarray
        ``(len(cells), channels, order + 1)`` complex scaled multipoles of those cells.
    lattice : Lattice
    order : int
    levels : list
        ``pass_levels`` of the wanted cells.
    orders : PassOrders, optional
        The terms each translation keeps, as a build's (``orders.pass_orders``); default every term.

    Returns
    -------
    list of numpy.ndarray
        Indexed by level: ``(len(levels[l].cells), channels, orders.kept(l) + 1)`` complex (None below level 2).
        ``cascade`` (with the same ``orders``) adds L2L; passes of one ``levels`` add up (the FMR is linear).
    """
    orders = uniform_orders(lattice.levels, order) if orders is None else orders
    if orders.width != order:
        raise ValueError(f"orders of width {orders.width} for expansions of order {order}")
    sources = _upward(cells, moments, lattice, order)
    offsets, masks = offset_parities()
    out: list[np.ndarray | None] = [None] * len(levels)
    for depth in range(2, lattice.levels + 1):
        level, (source_level, multipoles) = levels[depth], sources[depth]
        out[depth] = np.zeros((len(level.cells), moments.shape[1], orders.kept(depth) + 1), complex)
        _gathered_m2l(level.size, level.cells, source_level.row_of, _planes(multipoles), offsets, masks,
                      _terms_of(orders, depth), *_m2l_tables(order, float(np.log(lattice.level_size(depth)))),
                      out[depth])
    return out


@lru_cache(maxsize=256)
def _terms_of(orders: PassOrders, level: int) -> np.ndarray:
    """``(offsets, 2)`` the multipole and local terms of each translation of ``level`` (``_gathered_m2l``)."""
    return np.ascontiguousarray(np.stack([orders.multipole[level], orders.local[level]], axis=1) + 1, np.int64)


def cascade(m2l: list[np.ndarray | None], levels: list[_Level | None], order: int,
            only: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The fine cells' local expansions: ``interactions`` carried down the levels by L2L.

    Each level keeps the terms ``interactions`` gave it (``orders.kept``).  ``only`` (flat fine cells among
    ``levels``' own) limits the work to them and their ancestors.  Returns the fine cells (flat) and their
    expansions ``(cells, channels, kept + 1)``.
    """
    fine, local, above_rows = levels[-1], None, None
    for depth in range(2, len(levels)):
        level = levels[depth]
        if only is None:
            rows = np.arange(len(level.cells))
        else:
            shift = len(levels) - 1 - depth
            fine_rows, fine_columns = np.divmod(only, fine.size)
            rows = np.sort(level.row_of[np.unique((fine_rows >> shift) * level.size + (fine_columns >> shift))])
        level_local = np.take(m2l[depth], rows, axis=0)
        if local is not None:
            parent_rows = above_rows[levels[depth - 1].row_of[level.parents[rows]]]
            for start, stop, px, py in level.blocks():
                a, b = np.searchsorted(rows, (start, stop))  # rows are sorted and each parity's block contiguous
                matrix = l2l_matrix(child_offset(px, py), order)[: local.shape[-1], : level_local.shape[-1]]
                level_local[a:b] += times(np.take(local, parent_rows[a:b], axis=0), matrix)
        above_rows = np.full(len(level.cells), -1, np.int64)
        above_rows[rows] = np.arange(len(rows))
        local = level_local
    return fine.cells[rows], local


def sparse_local(cells: np.ndarray, moments: np.ndarray, lattice: Lattice, order: int,
                 wanted: np.ndarray | None = None, orders: PassOrders | None = None) -> np.ndarray:
    """The local expansions of sources in a few fine cells (``interactions``' parameters) at the ``wanted`` fine
    cells (bool ``(2^L, 2^L)``; default all): ``(2^L, 2^L, channels, kept + 1)`` complex, zero elsewhere."""
    n = lattice.cells_per_side
    levels = pass_levels(wanted, lattice)
    targets, local = cascade(interactions(cells, moments, lattice, order, levels, orders), levels, order)
    dense = np.zeros((n * n,) + local.shape[1:], complex)
    dense[targets] = local
    return dense.reshape((n, n) + local.shape[1:])


def delta_local(delta_fine: np.ndarray, lattice: Lattice, order: int, orders=None) -> np.ndarray:
    """Change of the fine local expansions for a change ``delta_fine`` of the fine multipoles.

    The build's compiled passes from the changed cells (``passes.level_sources``, ``passes.downward``): M2M
    up through their ancestors only, M2L into every cell (sparse levels gather from the occupied members
    of each interaction list, whole rows without one are skipped), L2L over whole levels (every cell's far
    field may change).

    Parameters
    ----------
    delta_fine : numpy.ndarray
        ``(2^L, 2^L, 3, order + 1)`` complex, zero where nothing changed.
    lattice : Lattice
    order : int
    orders : orders.PassOrders, optional
        The build's orders (``downward_pass``'s): each translation truncated alike.  Default: every term.

    Returns
    -------
    numpy.ndarray
        ``(2^L, 2^L, 3, order + 1)`` complex; equals ``downward_pass`` of
        ``coarser_multipoles(delta_fine)`` (with ``orders``) up to rounding.
    """
    n, channels = delta_fine.shape[0], delta_fine.shape[2]
    if channels != 3:  # the compiled passes are written for three channels
        return downward_pass(coarser_multipoles(delta_fine, order), lattice, order, orders)
    orders = uniform_orders(lattice.levels, order) if orders is None else orders
    if orders.width != order:
        raise ValueError(f"orders of width {orders.width} for expansions of order {order}")
    flat = delta_fine.reshape(n * n, channels, order + 1)
    cells = np.flatnonzero(np.any(flat != 0, axis=(1, 2)))
    return downward(level_sources(flat, cells, cells, lattice, orders), lattice, orders, order + 1)
