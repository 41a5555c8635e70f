"""The lattice of cells and the FMM passes over it (docs/design.md section 3).

A uniform ``2^L x 2^L`` lattice covers the canvas's bounding square with the
full quadtree above it.  Level arrays are indexed ``[row, column, ...]``.
The far field of a fine cell is everything outside its 3x3 block; each
level's multipole-to-local step is one matrix product per interaction offset
over strided slices of the whole level.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numba
import numpy as np

from ..geometry.discretise import cell_cuts
from ..geometry.segments import Segments, concatenate
from .expansions import l2l_matrix, m2l_matrix, m2m_matrix
from .moments import cell_moments, fine_moments_into


@lru_cache(maxsize=None)
def interaction_offsets(px: int, py: int) -> tuple[tuple[int, int], ...]:
    """Offsets from a cell to the members of its interaction list.

    Members are children of the parent's neighbours that are not the cell's
    own neighbours; ``px, py`` are the cell's column and row parity.
    """
    return tuple(
        (dx, dy)
        for dy in range(-3, 4)
        for dx in range(-3, 4)
        if max(abs(dx), abs(dy)) >= 2 and abs((px + dx) // 2) <= 1 and abs((py + dy) // 2) <= 1
    )


@lru_cache(maxsize=None)
def offset_parities() -> tuple[np.ndarray, np.ndarray]:
    """Every M2L offset ``(dx, dy)``, ``(k, 2)``, with the ``(k, 2, 2)`` masks of target parities ``[py, px]``
    using it."""
    masks: dict[tuple[int, int], np.ndarray] = {}
    for py in (0, 1):
        for px in (0, 1):
            for offset in interaction_offsets(px, py):
                masks.setdefault(offset, np.zeros((2, 2), bool))[py, px] = True
    offsets = sorted(masks)
    return np.array(offsets, dtype=np.int64), np.array([masks[o] for o in offsets])


def child_offset(px: int, py: int) -> complex:
    """(child centre - parent centre) / parent size for the child at parity (px, py)."""
    return complex((px - 0.5) / 2, (py - 0.5) / 2)


@dataclass(frozen=True)
class Lattice:
    """Geometry of the lattice.

    Parameters
    ----------
    levels : int
        Depth L >= 2; the fine level has ``2^L`` cells per side.
    side : float
        Side of the covered square ``[0, side]^2`` in pixels.
    """

    levels: int
    side: float

    @property
    def cells_per_side(self) -> int:
        return 2**self.levels

    @property
    def cell_size(self) -> float:
        return self.side / self.cells_per_side

    def level_size(self, level: int) -> float:
        return self.side / 2**level

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """Fine cell ``(row, column)`` of each point, ``(n, 2)`` int, clamped to the lattice."""
        index = np.floor(points[:, ::-1] / self.cell_size).astype(np.int64)
        return np.clip(index, 0, self.cells_per_side - 1)

    def cell_centres(self, cells: np.ndarray) -> np.ndarray:
        """Centres ``(n, 2)`` (x, y) of fine cells given as ``(row, column)``."""
        return (cells[:, ::-1] + 0.5) * self.cell_size


def distinct_cells(cells: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``numpy.unique(cells, return_inverse=True)`` for cells below ``count``, by marking (no sort)."""
    present = np.zeros(count, bool)
    present[cells] = True
    return np.flatnonzero(present), (np.cumsum(present) - 1)[cells]


def dilated(cells: np.ndarray) -> np.ndarray:
    """The boolean ``(n, n)`` cell mask ``cells`` grown by one cell every way (to the 3x3 blocks)."""
    grown = cells.copy()
    grown[1:] |= cells[:-1]
    grown[:-1] |= cells[1:]
    out = grown.copy()
    out[:, 1:] |= grown[:, :-1]
    out[:, :-1] |= grown[:, 1:]
    return out


def cell_order(segments: Segments, lattice: Lattice) -> tuple[np.ndarray, np.ndarray]:
    """The order sorting ``segments`` by fine cell (stable) and the CSR offsets of each cell's run.

    Returns
    -------
    order : numpy.ndarray
        ``segments.take(order)`` lists cell ``c = row * 2^L + column`` at
        ``cell_start[c]:cell_start[c + 1]``.
    cell_start : numpy.ndarray
        ``(4^L + 1,)`` int64.
    """
    return _midpoint_order(segments.midpoints, lattice)


def _midpoint_order(midpoints: np.ndarray, lattice: Lattice) -> tuple[np.ndarray, np.ndarray]:
    """``cell_order`` of segments with these midpoints (a counting sort: ``numpy.argsort(kind="stable")`` of
    the flat cells, measured 10-20x slower on 772,844 segments, is the reference)."""
    n = lattice.cells_per_side
    cell_start = np.zeros(n * n + 1, np.int64)
    order = np.empty(len(midpoints), np.int64)
    _counting_sort(np.ascontiguousarray(midpoints, dtype=np.float64), lattice.cell_size, n, cell_start, order)
    return order, cell_start


@numba.njit(cache=True)
def _counting_sort(midpoints, size, n, cell_start, order):
    """``cell_start`` (zeros in, CSR offsets out) and the stable ``order`` of the midpoints' fine cells."""
    flat = np.empty(len(midpoints), np.int64)
    for i in range(len(midpoints)):
        column = min(max(np.int64(np.floor(midpoints[i, 0] / size)), 0), n - 1)
        row = min(max(np.int64(np.floor(midpoints[i, 1] / size)), 0), n - 1)
        flat[i] = row * n + column
        cell_start[flat[i] + 1] += 1
    for c in range(n * n):
        cell_start[c + 1] += cell_start[c]
    filled = cell_start[:-1].copy()
    for i in range(len(midpoints)):
        order[filled[flat[i]]] = i
        filled[flat[i]] += 1


def sort_into_cells(segments: Segments, lattice: Lattice) -> tuple[Segments, np.ndarray]:
    """Segments sorted by fine cell and the CSR offsets of each cell's run: ``segments.take(order)`` and
    ``cell_start`` of ``cell_order`` (the reference).

    Each segment is read in turn and written to its place (a scatter: reading the rows in ``order`` misses the
    cache on nearly every row), and the sorted float fields are views of one block of memory: six arrays of a
    couple of megabytes each cost more in first-touch page faults than in copying.  Roses (89,883 segments):
    15-18 ms for ``cell_order`` and ``Segments.take``, 6-7 for this.
    """
    n = lattice.cells_per_side
    cell_start = np.zeros(n * n + 1, np.int64)
    destination = np.empty(len(segments), np.int64)
    _cell_destinations(np.ascontiguousarray(segments.p, dtype=np.float64),
                       np.ascontiguousarray(segments.q, dtype=np.float64), lattice.cell_size, n, cell_start,
                       destination)
    arrays = [getattr(segments, name) for name in _FLOAT_FIELDS]
    if any(a.dtype != np.float64 or a.ndim != 2 for a in arrays):
        order = np.empty_like(destination)
        order[destination] = np.arange(len(destination))
        return segments.take(order), cell_start
    block = np.empty(len(segments) * sum(a.shape[1] for a in arrays))
    fields, start = {}, 0
    for name, values in zip(_FLOAT_FIELDS, arrays):
        size = values.size
        fields[name] = block[start : start + size].reshape(values.shape)
        _scatter_rows(np.ascontiguousarray(values), destination, fields[name])
        start += size
    on_border = np.empty_like(segments.on_border)
    on_border[destination] = segments.on_border
    return Segments(on_border=on_border, **fields), cell_start


#: The float fields of ``Segments`` that ``sort_into_cells`` writes into one block.
_FLOAT_FIELDS = ("p", "q", "jump", "mean", "flux", "origin")


@numba.njit(cache=True)
def _cell_destinations(p, q, size, n, cell_start, destination):
    """``cell_start`` (zeros in) and each segment's place in the stable sort by the fine cell of its midpoint
    (``_counting_sort``'s, from the end points)."""
    for i in range(len(p)):
        cell_start[_midpoint_cell(p, q, i, size, n) + 1] += 1
    for c in range(n * n):
        cell_start[c + 1] += cell_start[c]
    filled = cell_start[:-1].copy()
    for i in range(len(p)):
        cell = _midpoint_cell(p, q, i, size, n)
        destination[i] = filled[cell]
        filled[cell] += 1


@numba.njit(cache=True, inline="always")
def _midpoint_cell(p, q, i, size, n):
    """The flat fine cell of segment ``i``'s midpoint, as ``Segments.midpoints`` computes it, clamped."""
    column = min(max(np.int64(np.floor(0.5 * (p[i, 0] + q[i, 0]) / size)), 0), n - 1)
    row = min(max(np.int64(np.floor(0.5 * (p[i, 1] + q[i, 1]) / size)), 0), n - 1)
    return row * n + column


@numba.njit(cache=True)
def _scatter_rows(values, destination, out):
    """``out[destination[i]] = values[i]``."""
    for i in range(destination.shape[0]):
        for j in range(values.shape[1]):
            out[destination[i], j] = values[i, j]


def cut_into_cells(segments: Segments, lattice: Lattice) -> tuple[Segments, np.ndarray]:
    """``sort_into_cells(cut_at_cells(segments, lattice.cell_size), lattice)``, the pieces made once, in order."""
    owner, t0, t1 = cell_cuts(segments, lattice.cell_size)
    start, step = segments.p[owner], (segments.q - segments.p)[owner]
    order, cell_start = _midpoint_order(0.5 * ((start + t0[:, None] * step) + (start + t1[:, None] * step)), lattice)
    return segments.split(owner[order], t0[order], t1[order]), cell_start


def merged(first: Segments, first_start: np.ndarray, second: Segments,
           second_start: np.ndarray) -> tuple[Segments, np.ndarray]:
    """Two sets of segments sorted by cell (with their CSR offsets) as one: in each cell, ``first``'s, then
    ``second``'s (``sort_into_cells`` of the two concatenated)."""
    order = np.empty(len(first) + len(second), np.int64)  # where each merged segment is in the two, one after the other
    order[np.arange(len(first)) + np.repeat(second_start[:-1], np.diff(first_start))] = np.arange(len(first))
    order[np.arange(len(second)) + np.repeat(first_start[1:], np.diff(second_start))] = len(first) + np.arange(
        len(second))
    return concatenate([first, second]).take(order), first_start + second_start


def fine_multipoles(segments: Segments, cell_start: np.ndarray, lattice: Lattice, order: int,
                    cells: np.ndarray | None = None) -> np.ndarray:
    """Scaled multipoles of the fine cells (P2M), ``(2^L, 2^L, 3, order + 1)`` complex.

    With ``cells`` (flat indices ``row * 2^L + column``), only theirs: ``(len(cells), 3, order + 1)``.
    """
    n = lattice.cells_per_side
    if cells is None:  # straight into the whole array, as a build's passes do
        occupied = np.flatnonzero(np.diff(cell_start))
        fine = np.zeros((n * n, 3, order + 1), complex)
        fine_moments_into(cell_start, occupied, lattice.cell_centres(np.stack(np.divmod(occupied, n), axis=1)),
                          lattice.cell_size, segments.p, segments.q, segments.flux, segments.jump, fine)
        return fine.reshape(n, n, 3, order + 1)
    flat = np.asarray(cells, np.int64)
    centres = lattice.cell_centres(np.stack(np.divmod(flat, n), axis=1))
    return cell_moments(cell_start, centres, lattice.cell_size, segments.p, segments.q, segments.flux, segments.jump,
                        order, cells=flat)


def changed_runs(before: Segments, before_start: np.ndarray, after: Segments, after_start: np.ndarray) -> np.ndarray:
    """Flat indices of the cells whose runs of sorted segments differ (in geometry, E or C).

    Compiled, field by field, skipping the cells already found to differ; ``changed_runs_reference`` is the
    plain form (roses, 89,883 segments: 34 ms for it, 3 for this).
    """
    fields = [(np.ascontiguousarray(getattr(before, name)), np.ascontiguousarray(getattr(after, name)))
              for name in ("p", "q", "flux", "jump")]
    differs = np.zeros(len(after_start) - 1, np.bool_)
    for old, new in fields:
        _differing_runs(before_start, after_start, old, new, differs)
    return np.flatnonzero(differs)


@numba.njit(cache=True)
def _differing_runs(before_start, after_start, old, new, differs):
    """Mark in ``differs`` the cells whose run of rows of ``old`` is not that of ``new`` (count or values)."""
    for cell in range(len(differs)):
        if differs[cell]:
            continue
        first, count = after_start[cell], after_start[cell + 1] - after_start[cell]
        shift = before_start[cell] - first
        if before_start[cell + 1] - before_start[cell] != count:
            differs[cell] = True
            continue
        for i in range(first, first + count):
            for j in range(new.shape[1]):
                if old[i + shift, j] != new[i, j]:
                    differs[cell] = True
                    break
            if differs[cell]:
                break


def changed_runs_reference(before: Segments, before_start: np.ndarray, after: Segments,
                           after_start: np.ndarray) -> np.ndarray:
    """``changed_runs`` in numpy."""
    counts = np.diff(after_start)
    same_count = counts == np.diff(before_start)
    cells = np.flatnonzero(same_count & (counts > 0))
    runs = counts[cells]
    firsts = np.cumsum(runs) - runs
    within = np.arange(runs.sum()) - np.repeat(firsts, runs)
    old = np.repeat(before_start[cells], runs) + within
    new = np.repeat(after_start[cells], runs) + within
    equal = np.ones(len(old), bool)
    for name in ("p", "q", "flux", "jump"):
        equal &= (getattr(before, name)[old] == getattr(after, name)[new]).all(axis=1)
    differs = ~same_count
    if len(runs):
        differs[cells[~np.minimum.reduceat(equal, firsts)]] = True
    return np.flatnonzero(differs)


def upward_pass(segments: Segments, cell_start: np.ndarray, lattice: Lattice, order: int) -> list[np.ndarray]:
    """Scaled multipoles of every cell at every level (P2M, then M2M).

    Returns
    -------
    list of numpy.ndarray
        ``multipoles[l]`` is ``(2^l, 2^l, 3, order + 1)`` complex for levels
        ``l = 2..L``; entries below 2 are None.
    """
    return coarser_multipoles(fine_multipoles(segments, cell_start, lattice, order), order)


def coarser_multipoles(fine: np.ndarray, order: int) -> list[np.ndarray | None]:
    """The fine level's multipoles and every coarser level's, by M2M up to level 2.

    Parameters
    ----------
    fine : numpy.ndarray
        ``(2^L, 2^L, channels, order + 1)`` scaled multipoles of the fine cells.

    Returns
    -------
    list of numpy.ndarray
        Indexed by level; entries below 2 are None.
    """
    levels = int(np.log2(fine.shape[0]))
    multipoles: list[np.ndarray | None] = [None] * (levels + 1)
    multipoles[levels] = fine
    for level in range(levels, 2, -1):
        child = multipoles[level]
        parent = np.zeros((2 ** (level - 1),) * 2 + child.shape[2:], complex)
        for py in (0, 1):
            for px in (0, 1):
                parent += times(child[py::2, px::2], m2m_matrix(child_offset(px, py), order))
        multipoles[level - 1] = parent
    return multipoles


def downward_pass(multipoles: list[np.ndarray], lattice: Lattice, order: int, orders=None) -> np.ndarray:
    """Scaled local expansions of the far field of every fine cell (M2L, L2L); the reference of ``passes``.

    Parameters
    ----------
    multipoles : list of numpy.ndarray
        ``coarser_multipoles`` of the fine cells.
    lattice : Lattice
    order : int
        Terms of the expansions, minus one.
    orders : orders.PassOrders, optional
        Each M2L keeps the multipole terms ``<= m`` and writes the local terms
        ``<= q`` of its level and offset, and each level keeps the local terms
        ``<= orders.kept(level)``.  Default: every term up to ``order``.

    Returns
    -------
    numpy.ndarray
        ``(2^L, 2^L, 3, order + 1)`` complex.
    """
    local = None
    for level in range(2, lattice.levels + 1):
        log_size = float(np.log(lattice.level_size(level)))
        sources = _parity_grids(multipoles[level])
        half = multipoles[level].shape[0] // 2
        level_local = np.empty_like(multipoles[level])
        for py in (0, 1):
            for px in (0, 1):
                target = np.zeros((half, half) + multipoles[level].shape[2:], complex)
                if local is not None:
                    target += times(local, l2l_matrix(child_offset(px, py), order))
                rows = target.reshape(half, -1, order + 1)
                for dx, dy in interaction_offsets(px, py):
                    row0, col0 = _PAD // 2 + (py + dy) // 2, _PAD // 2 + (px + dx) // 2
                    window = sources[(py + dy) % 2][(px + dx) % 2][row0 : row0 + half, col0 : col0 + half]
                    matrix = m2l_matrix(complex(dx, dy), order, log_size)
                    if orders is not None:
                        matrix = _truncated(matrix, *orders.of(level, (dx, dy)))
                    rows += window.reshape(half, -1, order + 1) @ matrix
                if orders is not None:
                    target[..., orders.kept(level) + 1 :] = 0.0
                level_local[py::2, px::2] = target
        local = level_local
    return local


def _truncated(matrix: np.ndarray, multipole: int, local: int) -> np.ndarray:
    """``matrix`` with the rows past ``multipole`` and the columns past ``local`` zero."""
    kept = np.zeros_like(matrix)
    kept[: multipole + 1, : local + 1] = matrix[: multipole + 1, : local + 1]
    return kept


def times(expansions: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``expansions @ matrix`` over the last axis as one product (numpy loops over stacked small ones: 4x slower)."""
    return (expansions.reshape(-1, matrix.shape[0]) @ matrix).reshape(expansions.shape[:-1] + (matrix.shape[1],))


#: Zero cells around a level for the interaction-list windows (even, so parities are kept).
_PAD = 4


def _parity_grids(level: np.ndarray) -> list[list[np.ndarray]]:
    """The zero-padded level split by row and column parity, each contiguous.

    ``grids[qy][qx][a, b]`` is padded cell ``(2a + qy, 2b + qx)``; a window of
    rows of one grid is then a stack of contiguous matrices that BLAS
    multiplies in one call per row.
    """
    n = level.shape[0]
    padded = np.zeros((n + 2 * _PAD, n + 2 * _PAD) + level.shape[2:], complex)
    padded[_PAD:-_PAD, _PAD:-_PAD] = level
    return [[np.ascontiguousarray(padded[qy::2, qx::2]) for qx in (0, 1)] for qy in (0, 1)]
