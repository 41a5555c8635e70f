"""A build's upward and downward passes, compiled, each translation at the orders of ``orders.pass_orders``.

``lattice.upward_pass`` and ``lattice.downward_pass`` (with the same
orders) are the reference.  The work follows the occupied cells:

- P2M only in occupied fine cells; their moments at full width are what
  ``Cells`` keeps (``fine``), the passes read the first ``carried`` terms.
- A level is *dense* when at least ``DENSE_SHARE`` of its cells are
  occupied (and it is ``DENSE_SIDE`` cells wide), else *sparse*
  (``level_kernels``): dense levels run M2M and M2L as row sweeps over
  whole grids, sparse ones M2M from the occupied children and M2L gathered
  per target from the occupied members of its list.  A sparse level above
  a dense one takes its occupied cells' multipoles out of the grid that
  M2M made (``_grid_values``).
- Every target cell gets its local expansion (pixels need all of them), with
  ``orders.kept(level)`` terms; the fine level's are written straight into
  the array ``Cells`` keeps, zero past ``kept``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from . import level_kernels as kernels
from .expansions import l2l_matrix, m2l_matrix, m2m_matrix
from .lattice import Lattice, child_offset, distinct_cells, interaction_offsets
from .moments import fine_moments_into
from .orders import PassOrders

#: Occupied share of a level's cells from which its passes run as row sweeps over the whole level: the
#: crossover of the two M2L kernels (at L9 a dense fine level's sweep cost 0.71-0.82 s of one core, the
#: gather at 7% occupied 0.32 s).
DENSE_SHARE = 0.15

#: Cells per side below which a level is always sparse: row sweeps of a few cells are mostly loop overhead.
#: Gathered, the levels 2 to 4 of the boundary solve's products (order 20, every cell occupied) took 0.3,
#: 0.7 and 2.6-3.3 ms, as grids 0.3-1.1, 0.7-2.5 and 7.1-7.3 ms (lady_bug, fruits, roses); 32 cells wide
#: (half of them occupied) both took 9-14 ms.
DENSE_SIDE = 32

#: M2L term pairs (``_term_pairs``) of a fine cell of the editor's builds (pixels of degree 8): the cell of
#: work ``level_kernels.PARALLEL_CELLS`` counts in.  A cell of the solve's products (order 20) is 6 of them.
CELL_TERM_PAIRS = 2868

#: Cells of work from which a build's whole-level M2L and L2L run on both cores (``build_passes``; an edit's
#: change of the levels and a solve's products, many calls, keep ``level_kernels.PARALLEL_CELLS``).  A level of
#: 256 cells takes 0.8-2.5 ms on one core, 0.4-1.1 on two (the Hilbert scenes' L4 and L5 at L5-L7); the second
#: thread's wake-up, 4-8 ms while another process holds a core, is paid once a level where it is late, not once
#: a call of an edit's.
BUILD_PARALLEL_CELLS = 256

_NO_GRID = np.zeros((0,) * 6)
_NO_SOURCES = np.zeros((0, 0, 0))
_NO_INDEX = np.zeros((0, 0), np.int64)
_NO_PLANES = np.zeros((0, 0, 0, 0))
_NO_FINE = np.zeros((0, 0, 0, 0), complex)
_NO_CHANGE = np.zeros((0, 0))
_NO_CENTRES = np.zeros((0, 0, 3))


@dataclass(frozen=True)
class LevelSources:
    """One level's multipoles as the kernels read them: a grid (dense level) or its occupied cells (sparse)."""

    grid_re: np.ndarray = field(default_factory=lambda: _NO_GRID)
    grid_im: np.ndarray = field(default_factory=lambda: _NO_GRID)
    src_re: np.ndarray = field(default_factory=lambda: _NO_SOURCES)
    src_im: np.ndarray = field(default_factory=lambda: _NO_SOURCES)
    index: np.ndarray = field(default_factory=lambda: _NO_INDEX)

    @property
    def dense(self) -> bool:
        return self.grid_re.size > 0


def _even(terms: int) -> int:
    return terms + terms % kernels.PAIR


@lru_cache(maxsize=256)
def _carried_terms(orders: PassOrders, level: int) -> int:
    """Multipole terms (even) the cells of ``level`` carry."""
    return _even(orders.carried(level) + 1)


def _index_map(cells: np.ndarray, size: int) -> np.ndarray:
    """``(size + 2 INDEX_PAD)^2`` map from a cell to its position in ``cells`` (flat, sorted), -1 elsewhere."""
    index = np.full((size + 2 * kernels.INDEX_PAD,) * 2, -1, np.int64)
    rows, columns = np.divmod(cells, size)
    index[rows + kernels.INDEX_PAD, columns + kernels.INDEX_PAD] = np.arange(len(cells))
    return index


def _empty_grid(size: int, terms: int) -> tuple[np.ndarray, np.ndarray]:
    side = size // 2 + 2 * kernels.GRID_PAD
    return np.zeros((2, 2, side, terms, 3, side)), np.zeros((2, 2, side, terms, 3, side))


@lru_cache(maxsize=64)
def _m2m_tables(child_terms: int, parent_terms: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """``(4, child_terms, parent_terms)`` M2M matrices of the child parities ``2 py + px``."""
    matrices = np.zeros((4, child_terms, parent_terms), complex)
    order = max(child_terms, parent_terms, width + 1) - 1
    for parity in range(4):
        full = m2m_matrix(child_offset(parity % 2, parity // 2), order)
        matrices[parity] = full[:child_terms, :parent_terms]
    return np.ascontiguousarray(matrices.real), np.ascontiguousarray(matrices.imag)


@lru_cache(maxsize=64)
def _m2m_rows(child_terms: int, parent_terms: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """``_m2m_tables`` transposed, ``(4, parent_terms, child_terms)``: one row per parent term."""
    return tuple(np.ascontiguousarray(part.transpose(0, 2, 1)) for part in _m2m_tables(child_terms, parent_terms,
                                                                                        width))


def upward(segments, cell_start: np.ndarray, lattice: Lattice, orders: PassOrders,
           lap: Callable[[str], None] | None = None) -> tuple[np.ndarray, list[LevelSources | None]]:
    """P2M and M2M: the fine multipoles at full width ``(2^L, 2^L, 3, width + 1)`` and every level's sources.

    ``lap("P2M")``, if given, is called between the two (a benchmark's breakdown).
    """
    n, width = lattice.cells_per_side, orders.width
    cells = np.flatnonzero(np.diff(cell_start))
    centres = lattice.cell_centres(np.stack(np.divmod(cells, n), axis=1))
    fine = huge_pages_zeros((n, n, 3, width + 1), complex)
    moments = fine.reshape(n * n, 3, width + 1)  # a view: P2M writes the fine multipoles in place
    fine_moments_into(cell_start, cells, centres, lattice.cell_size, segments.p, segments.q, segments.flux,
                      segments.jump, moments)
    if lap is not None:
        lap("P2M")
    return fine, level_sources(moments, cells, cells, lattice, orders)


def level_sources(moments: np.ndarray, rows: np.ndarray, cells: np.ndarray, lattice: Lattice,
                  orders: PassOrders) -> list[LevelSources | None]:
    """Every level's sources (M2M) from the multipoles ``moments[rows[i]]`` of the fine cells ``cells[i]``.

    Parameters
    ----------
    moments : numpy.ndarray
        ``(m, 3, >= 1)`` complex fine multipoles (terms past ``width`` are not read).
    rows, cells : numpy.ndarray
        The row of ``moments`` of each fine cell (flat ``row * 2^L + column``, sorted, distinct) that holds
        sources; every other cell holds none.
    """
    n, width = lattice.cells_per_side, orders.width
    values_re = values_im = None  # a sparse level's multipoles, as planes
    sources: list[LevelSources | None] = [None] * (lattice.levels + 1)
    grid = None  # a dense level's multipoles, as its grid
    for level in range(lattice.levels, 1, -1):
        size, terms = 2**level, _carried_terms(orders, level)
        if len(cells) >= _dense_count(size):
            if grid is None:
                grid = _empty_grid(size, terms)
                with kernels.threads_for(size * size):
                    if values_re is None:  # the fine level: ``moments`` as they are
                        position = np.full(n * n, -1, np.int64)
                        position[cells] = rows
                        kernels.fill_grid_complex(position.reshape(n, n), moments, *grid)
                    else:
                        pad = kernels.INDEX_PAD
                        kernels.fill_grid(_index_map(cells, size)[pad:-pad, pad:-pad], values_re, values_im, *grid)
            sources[level] = LevelSources(grid_re=grid[0], grid_im=grid[1])
            if level > 2:
                parent_terms = _carried_terms(orders, level - 1)
                parent = _empty_grid(size // 2, parent_terms)
                with kernels.threads_for(size * size):
                    kernels.grid_m2m(*grid, *_m2m_tables(terms, parent_terms, width), *parent)
                grid = parent
            cells = _parents(cells, size)
            continue
        index = _index_map(cells, size)
        if grid is not None:  # a sparse level above a dense one
            values_re, values_im = _grid_values(grid, cells, size)
            grid = None
        elif values_re is None:
            values_re, values_im = _split(moments[rows], terms)
        sources[level] = LevelSources(src_re=values_re, src_im=values_im, index=index)
        if level > 2:
            parents = _parents(cells, size)
            parent_terms = _carried_terms(orders, level - 1)
            values_re, values_im = (np.zeros((len(parents), 3, parent_terms)) for _ in range(2))
            with kernels.threads_for(len(cells)):
                kernels.compact_m2m(size, parents, index, sources[level].src_re, sources[level].src_im,
                                    *_m2m_rows(terms, parent_terms, width), values_re, values_im)
            cells = parents
    return sources


def _grid_values(grid: tuple[np.ndarray, np.ndarray], cells: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The multipoles ``(len(cells), 3, K)`` (planes) of the cells ``cells`` (flat) of a level's grid."""
    rows, columns = np.divmod(cells, size)
    pad = kernels.GRID_PAD
    at = (rows % 2, columns % 2, rows // 2 + pad, slice(None), slice(None), columns // 2 + pad)
    return tuple(np.ascontiguousarray(part[at].transpose(0, 2, 1)) for part in grid)


def _dense_count(size: int) -> int:
    """Occupied cells from which a level of ``size`` cells per side counts as dense (never below ``DENSE_SIDE``)."""
    return int(np.ceil(DENSE_SHARE * size * size)) if size >= DENSE_SIDE else size * size + 1


def _parents(cells: np.ndarray, size: int) -> np.ndarray:
    """The parents (flat, sorted, distinct) of the cells ``cells`` (flat) of a level ``size`` cells wide."""
    rows, columns = np.divmod(cells, size)
    return distinct_cells((rows // 2) * (size // 2) + columns // 2, size * size // 4)[0]


def _split(moments: np.ndarray, terms: int) -> tuple[np.ndarray, np.ndarray]:
    """Real and imaginary planes ``(cells, 3, terms)`` of the first terms of complex ``moments``, zero-padded."""
    head = moments[..., :terms]
    planes = np.zeros((2,) + moments.shape[:-1] + (terms,))
    planes[0, ..., : head.shape[-1]] = head.real
    planes[1, ..., : head.shape[-1]] = head.imag
    return planes[0], planes[1]


@lru_cache(maxsize=None)
def _static_offset_table() -> tuple[np.ndarray, np.ndarray]:
    """``level_kernels.offset_table`` rows (orders left zero) of every parity, and where each parity starts."""
    rows, starts = [], [0]
    for parity in range(4):
        py, px = divmod(parity, 2)
        for dx, dy in interaction_offsets(px, py):
            rows.append((dx, dy, (py + dy) % 2, (px + dx) % 2, (py + dy) // 2, (px + dx) // 2, 0, 0))
        starts.append(len(rows))
    return np.array(rows, np.int64), np.array(starts, np.int64)


@lru_cache(maxsize=64)
def _level_tables(orders: PassOrders, level: int, log_size: float) -> tuple[np.ndarray, ...]:
    """The offset table, its starts and the truncated M2L matrices ``(rows, K, Q)`` (planes) of ``level``."""
    table, starts = _static_offset_table()
    table = table.copy()
    terms = _carried_terms(orders, level)
    kept = orders.kept(level) + 1
    matrices = np.zeros((len(table), terms, kept), complex)
    for row, (dx, dy) in enumerate(table[:, :2]):
        m, q = orders.of(level, (int(dx), int(dy)))
        table[row, kernels.PAIRS] = (m + kernels.PAIR) // kernels.PAIR
        table[row, kernels.LOCAL] = q
        matrices[row, : m + 1, : q + 1] = m2l_matrix(complex(dx, dy), orders.width, log_size)[: m + 1, : q + 1]
    return table, starts, np.ascontiguousarray(matrices.real), np.ascontiguousarray(matrices.imag)


@lru_cache(maxsize=256)
def _term_pairs(orders: PassOrders, level: int) -> int:
    """Multipole-local term pairs of ``level``'s translations, summed over the offsets (its cells' M2L work)."""
    return int(((orders.multipole[level] + 1) * (orders.local[level] + 1)).sum())


@lru_cache(maxsize=64)
def _l2l_tables(parent_terms: int, child_terms: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """``(4, parent_terms, child_terms)`` L2L matrices of the child parities ``2 py + px``."""
    matrices = np.zeros((4, parent_terms, child_terms), complex)
    for parity in range(4):
        full = l2l_matrix(child_offset(parity % 2, parity // 2), width)
        matrices[parity, : min(parent_terms, width + 1), :child_terms] = full[:parent_terms, :child_terms]
    return np.ascontiguousarray(matrices.real), np.ascontiguousarray(matrices.imag)


def downward(sources: list[LevelSources | None], lattice: Lattice, orders: PassOrders,
             terms: int | None = None, lap: Callable[[str], None] | None = None,
             centres: np.ndarray | None = None, parallel_from: float = kernels.PARALLEL_CELLS) -> np.ndarray:
    """M2L and L2L: the fine cells' local expansions ``(2^L, 2^L, 3, terms)`` complex, zero past ``kept``.

    ``terms`` (at least the fine level's ``kept + 1``) defaults to ``width + 1``; ``lap(f"L{level}")``, if
    given, is called after each level's M2L and L2L; ``centres``, if given (``(2^L, 2^L, 3)`` float), is filled
    with the far field at each fine cell's centre as the expansions are written (``Cells.centres``).  A level runs
    on both cores from ``parallel_from`` cells of work (a build's: ``BUILD_PARALLEL_CELLS``).

    Each level's entry of ``sources`` is set to None once its translations are done, so that the coarse
    levels' grids are freed before the fine level's local expansions fill (77 MB of a 1.2 GB peak at L 9).
    """
    n = lattice.cells_per_side
    local = huge_pages_zeros((n, n, 3, orders.width + 1 if terms is None else terms), complex)
    _downward(sources, lattice, orders, local, _NO_FINE, _NO_CHANGE, _centres_out(centres, n), lap, parallel_from)
    return local


def downward_onto(sources: list[LevelSources | None], lattice: Lattice, orders: PassOrders,
                  base: np.ndarray, out: np.ndarray | None = None,
                  centres: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``base`` plus ``downward`` of ``sources`` (an edit's change), without the change as an array of its own.

    Parameters
    ----------
    sources : list
        ``level_sources`` of the change of the fine multipoles (set to None level by level, as ``downward``).
    base : numpy.ndarray
        ``(2^L, 2^L, 3, K)`` complex fine local expansions, ``K`` at least the fine level's ``kept + 1``.
    out : numpy.ndarray, optional
        Where to write the sum (C-contiguous, ``base``'s shape and type, not ``base``); default a new array.
    centres : numpy.ndarray, optional
        ``(2^L, 2^L, 3)`` float, filled with the sum's far field at each cell's centre (``downward``'s).

    Returns
    -------
    local : numpy.ndarray
        ``out``: ``base`` plus the change (zero past ``kept``).
    change : numpy.ndarray
        ``(2^L, 2^L)`` largest real or imaginary part of each cell's change (``cells.largest_part``).
    """
    n = lattice.cells_per_side
    local, change = huge_pages_empty(base.shape, base.dtype) if out is None else out, np.empty((n, n))
    _downward(sources, lattice, orders, local, np.ascontiguousarray(base), change, _centres_out(centres, n), None)
    return local, change


def _centres_out(centres: np.ndarray | None, n: int) -> np.ndarray:
    """``centres`` checked as the kernels' output of a lattice of ``n`` cells a side (None: none, empty)."""
    if centres is None:
        return _NO_CENTRES
    if centres.shape != (n, n, 3) or centres.dtype != np.float64 or not centres.flags.c_contiguous:
        raise ValueError(f"centres must be a C-contiguous float64 array of the shape {(n, n, 3)}")
    return centres


#: Bytes of a huge page, and the size from which ``huge_pages_empty`` places an array on them.
HUGE_PAGE = 1 << 21
HUGE_FROM = 1 << 20
#: Bytes from which numpy itself asks for huge pages for a new array.
NUMPY_HUGE_FROM = 4 << 20


def huge_pages_empty(shape: tuple[int, ...], dtype) -> np.ndarray:
    """``numpy.empty(shape, dtype)``, from ``HUGE_FROM`` bytes on placed at a huge page's start in a larger block.

    numpy asks for huge pages for blocks of 4 MB or more, and the kernel gives them only to whole aligned 2 MB
    ranges.  A fresh array of a few megabytes otherwise pays a page fault per 4 kB, about 0.7 ms per MB on this
    machine's VM: 1.27 ms to fill 1.8 MB (lady_bug's local expansions) against 0.22 on huge pages.  The block
    past the array is never touched, so it costs address space, not memory (at most the rest of a 2 MB page).
    """
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dtype.itemsize
    if nbytes < HUGE_FROM:
        return np.empty(shape, dtype)
    raw = np.empty(max(nbytes, 2 * HUGE_PAGE) + HUGE_PAGE, np.uint8)
    start = -raw.ctypes.data % HUGE_PAGE
    return raw[start : start + nbytes].view(dtype).reshape(shape)


def huge_pages_zeros(shape: tuple[int, ...], dtype) -> np.ndarray:
    """``numpy.zeros(shape, dtype)``, on huge pages from ``HUGE_FROM`` bytes (``huge_pages_empty``).

    Below the 4 MB from which numpy asks for huge pages itself, a fresh array of zeros is paid for by a page
    fault per 4 kB as it is written: 2.2 ms for the 3.3 MB of a level 6's fine multipoles, 0.4 on huge pages.
    """
    if np.prod(shape) * np.dtype(dtype).itemsize >= NUMPY_HUGE_FROM:
        return np.zeros(shape, dtype)
    out = huge_pages_empty(shape, dtype)
    out.fill(0)
    return out


def _downward(sources: list[LevelSources | None], lattice: Lattice, orders: PassOrders, local: np.ndarray,
              base: np.ndarray, change: np.ndarray, centres: np.ndarray, lap: Callable[[str], None] | None,
              parallel_from: float = kernels.PARALLEL_CELLS) -> None:
    """``downward`` into ``local``; with a ``base`` (not empty), ``downward_onto``.  A level runs on both cores
    from ``parallel_from`` cells of work."""
    if local.shape[-1] < orders.kept(lattice.levels) + 1:
        raise ValueError(f"the fine level keeps {orders.kept(lattice.levels) + 1} local terms, not {local.shape[-1]}")
    parent_re = parent_im = _NO_PLANES
    l2l = (np.zeros((0, 0, 0)), np.zeros((0, 0, 0)))
    for level in range(2, lattice.levels + 1):
        size, kept = 2**level, orders.kept(level) + 1
        level_sources = sources[level]
        if level > 2:
            l2l = _l2l_tables(parent_re.shape[1], kept, orders.width)
        fine = level == lattice.levels
        coarse = (_NO_PLANES, _NO_PLANES) if fine else (np.zeros((size, _even(kept), 3, size)),
                                                         np.zeros((size, _even(kept), 3, size)))
        tables = _level_tables(orders, level, float(np.log(lattice.level_size(level))))
        with kernels.threads_for(size * size * _term_pairs(orders, level) / CELL_TERM_PAIRS, parallel_from):
            kernels.level_local(size, parent_re, parent_im, *l2l, level_sources.grid_re, level_sources.grid_im,
                                level_sources.src_re, level_sources.src_im, level_sources.index, *tables, kept,
                                *coarse, local if fine else _NO_FINE, base if fine else _NO_FINE,
                                change if fine else _NO_CHANGE, centres if fine else _NO_CENTRES)
        sources[level] = level_sources = None
        parent_re, parent_im = coarse
        if lap is not None:
            lap(f"L{level}")


def build_passes(segments, cell_start: np.ndarray, lattice: Lattice, orders: PassOrders,
                 lap=lambda stage: None, terms: int | None = None,
                 centres: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fine multipoles and fine local expansions (``terms`` of them, ``downward``'s) of sorted ``segments``
    (``lap("upward")`` between the passes; ``centres`` as ``downward``'s)."""
    fine, sources = upward(segments, cell_start, lattice, orders)
    lap("upward")
    return fine, downward(sources, lattice, orders, terms, centres=centres, parallel_from=BUILD_PARALLEL_CELLS)
