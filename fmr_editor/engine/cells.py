"""The cells of a representation: solved segments sorted by cell, their multipoles and local expansions.

``Cells`` is an immutable snapshot: an edit makes new ``Cells`` from the
old ones (``propagated``), carrying only the change of the fine multipoles
up the quadtree from the cells that changed and down through the
interaction lists and every level (``passes.level_sources``,
``passes.downward_onto``).  The FMR is linear in its sources, so that
change of the local expansions is exact.  Every local expansion changes, so
each snapshot has its own; the multipoles of a preview are a patch of a few
cells on the last exact snapshot's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property

import numba
import numpy as np

from .fmm.far_field import far_field_at
from .fmm.lattice import (
    Lattice,
    cell_order,
    changed_runs,
    coarser_multipoles,
    downward_pass,
    fine_multipoles,
    sort_into_cells,
)
from .fmm.level_kernels import threads_for
from .fmm.orders import PassOrders, pass_orders, uniform_orders
from .fmm.passes import build_passes, downward_onto, level_sources
from .geometry.segments import Segments
from .kernels.segment_sums import near_sum, near_tables

#: A fine cell whose multipoles changed by less than this share of the solve's
#: own accuracy (relative to the largest multipole) keeps the change pending:
#: it is added with a later one.  Such changes are mostly the solve's noise.
NEGLIGIBLE = 0.1


@dataclass(frozen=True, eq=False)
class Cells:
    """Solved segments sorted by fine cell, the fine cells' multipoles and their local expansions.

    Attributes
    ----------
    segments : Segments
        Sorted by fine cell.
    cell_start : numpy.ndarray
        CSR offsets of each fine cell's segments.
    fine_base : numpy.ndarray
        ``(2^L, 2^L, 3, P + 1)`` complex scaled multipoles of the fine cells
        but ``patched_cells`` (``fine`` is all of them).
    local : numpy.ndarray
        ``(2^L, 2^L, 3, K)`` complex scaled local expansions of each fine
        cell's far field: ``K = N + 1`` terms with chosen ``orders`` (the
        pixels read no more: half the memory of ``P + 1`` at N = 8), else
        ``P + 1``.
    orders : PassOrders or None
        The terms each translation carried (``orders.pass_orders``); edits carry
        their change with the same.  None: every term.
    patched_cells, patched_fine : numpy.ndarray or None
        Flat fine cells (sorted) whose multipoles ``(len, 3, P + 1)`` are these
        instead of ``fine_base``'s: a preview changes a few cells of a shared
        ``fine_base`` instead of copying it (53 MB at roses' L8).
    centres : numpy.ndarray or None
        ``(2^L, 2^L, 3)`` the far field at each fine cell's centre, ``Re L_0 / 2 pi``, written by the downward
        pass beside ``local`` (a raster whose samples lie on the centres reads these, not a cell's whole
        expansion); None where not made (``Representation.centre_values`` takes them from ``local``).
    """

    segments: Segments
    cell_start: np.ndarray
    fine_base: np.ndarray
    local: np.ndarray
    orders: PassOrders | None = None
    patched_cells: np.ndarray | None = None
    patched_fine: np.ndarray | None = None
    centres: np.ndarray | None = None

    @property
    def fine(self) -> np.ndarray:
        """``(2^L, 2^L, 3, P + 1)`` complex scaled multipoles of the fine cells (with a patch, made on first use)."""
        return self.fine_base if self.patched_cells is None else self._patched_whole

    @cached_property
    def _patched_whole(self) -> np.ndarray:
        whole = self.fine_base.copy()
        whole.reshape(-1, *whole.shape[2:])[self.patched_cells] = self.patched_fine
        return whole

    def moved_from(self, other: Cells) -> np.ndarray:
        """``(2^L, 2^L)`` bool: the fine cells whose multipoles differ from ``other``'s (of the same lattice).

        Two patches of one snapshot differ only where either is patched: no whole array is made for them.
        """
        if self.fine_base is not other.fine_base:
            return np.any(self.fine != other.fine, axis=(2, 3))
        n = self.fine_base.shape[0]
        cells = np.union1d(*(np.zeros(0, np.int64) if each.patched_cells is None else each.patched_cells
                             for each in (self, other)))
        moved = np.zeros(n * n, bool)
        moved[cells] = np.any(self.fine_of(cells) != other.fine_of(cells), axis=(1, 2))
        return moved.reshape(n, n)

    def fine_of(self, cells: np.ndarray) -> np.ndarray:
        """The multipoles ``(len(cells), 3, P + 1)`` of the fine cells ``cells`` (flat)."""
        base = self.fine_base
        rows = base.reshape(-1, *base.shape[2:])[cells]
        if self.patched_cells is not None:
            at = np.minimum(np.searchsorted(self.patched_cells, cells), len(self.patched_cells) - 1)
            patched = self.patched_cells[at] == cells
            rows[patched] = self.patched_fine[at[patched]]
        return rows

    @classmethod
    def build(cls, solved: Segments, lattice: Lattice, order: int, lap: Callable[[str], None] = lambda stage: None,
              pixel_order: int | None = None) -> Cells:
        """The cells of ``solved`` segments: P2M, M2M (``lap("upward")``), M2L and L2L (``lap("downward")``).

        Parameters
        ----------
        solved : Segments
        lattice : Lattice
        order : int
            Highest term of the expansions kept (``Settings.propagation_order``).
        lap : callable, optional
            Called after each pass with its name.
        pixel_order : int or None
            Degree of the pixels' polynomials (``Settings.order``): each translation carries the terms
            the pixels' accuracy needs (``orders.pass_orders``), 2-3x faster at L 9 than every term; the
            editor's builds pass it.  None: every term up to ``order``, as files saved before were made (a
            reference for them, and for the passes).
        """
        segments, cell_start = sort_into_cells(solved, lattice)
        orders = (uniform_orders(lattice.levels, order) if pixel_order is None
                  else pass_orders(lattice.levels, min(pixel_order, order), order))
        centres = _centres_for(lattice)
        fine, local = build_passes(segments, cell_start, lattice, orders, lap, _local_terms(order, pixel_order),
                                   centres)
        lap("downward")
        return cls(segments, cell_start, fine, local, None if pixel_order is None else orders, centres=centres)

    @classmethod
    def resume(cls, solved: Segments, lattice: Lattice, order: int, local: np.ndarray,
               pixel_order: int | None = None) -> Cells:
        """The cells of ``solved`` segments whose local expansions ``local`` are known (a saved file).

        Edits carry their change with the orders a build for ``pixel_order`` uses (``build``'s parameter), so
        that they equal a rebuild's; ``local`` is then kept to the pixels' terms (a copy).
        """
        segments, cell_start = sort_into_cells(solved, lattice)
        orders = None if pixel_order is None else pass_orders(lattice.levels, min(pixel_order, order), order)
        local = np.array(local[..., : _local_terms(order, pixel_order)], dtype=complex)
        return cls(segments, cell_start, fine_multipoles(segments, cell_start, lattice, order), local, orders)

    def field_at(self, points: np.ndarray, lattice: Lattice) -> np.ndarray:
        """The segments' field ``(m, 3)`` at ``points`` off them: the local expansions plus each point's 3x3
        block of segments (``evaluate_points`` without diffusion points)."""
        seg = self.segments
        return far_field_at(self.local, lattice, lattice.cell_of(points), points) + near_sum(
            points, lattice.cells_per_side, lattice.cell_size, self.cell_start, seg.p, seg.q, seg.flux, seg.jump,
            tables=self._near_tables)

    @cached_property
    def _near_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """``near_tables`` of the segments, made by the first ``field_at`` (a drag's previews ask it again)."""
        seg = self.segments
        return near_tables(seg.p, seg.q, seg.flux, seg.jump)

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays held (shared ones counted too)."""
        patch = 0 if self.patched_cells is None else self.patched_cells.nbytes + self.patched_fine.nbytes
        centres = 0 if self.centres is None else self.centres.nbytes
        return (self.segments.nbytes + self.cell_start.nbytes + self.fine_base.nbytes + patch + self.local.nbytes
                + centres)


def propagated(cells: Cells, solved: Segments, lattice: Lattice, order: int, accuracy: float,
               only_moved: bool = False) -> tuple[Cells, np.ndarray, np.ndarray]:
    """``cells`` brought to the ``solved`` segments by the change of their multipoles.

    Only the rows of the fine cells that moved are made anew; the change goes
    down the tree from them (``passes.level_sources``, ``passes.downward_onto``)
    and is added to the local expansions as they are written.  A preview's
    multipoles are a patch of ``cells``' (``Cells.patched_cells``) until the
    patch passes ``PATCH_SHARE`` of the cells; an exact step writes them whole.
    ``propagated_reference`` is the plain form.

    Parameters
    ----------
    accuracy : float
        Relative accuracy of the solved densities: fine cells whose multipoles
        moved by less than ``NEGLIGIBLE`` of it keep their old ones (the change
        waits for a later one).
    only_moved : bool
        True when only segments that moved or were replaced changed (a
        preview keeps every other density): only their cells' multipoles are
        made again.

    Returns
    -------
    cells : Cells
        When no fine cell moved, it shares ``cells``' multipoles and local expansions (and patch).
    local_change : numpy.ndarray
        ``(2^L, 2^L)`` size of the change of each cell's local expansion (``largest_part``).
    moved : numpy.ndarray
        ``(2^L, 2^L)`` bool: fine cells whose multipoles changed.
    """
    segments, cell_start = sort_into_cells(solved, lattice)
    n = lattice.cells_per_side
    if only_moved:
        changed = changed_runs(cells.segments, cells.cell_start, segments, cell_start)
        with threads_for(len(changed)):
            fresh = fine_multipoles(segments, cell_start, lattice, order, changed)
        before = cells.fine_of(changed)
        sizes = largest_part(fresh - before, axis=(1, 2))
        if accuracy > 0:
            sizes_before = largest_part(cells.fine, axis=(2, 3)).ravel()
            sizes_before[changed] = largest_part(fresh, axis=(1, 2))
            scale = max(float(sizes_before.max(initial=0.0)), 1e-300)
        else:  # the threshold is zero whatever the scale
            scale = 1.0
        kept = sizes > NEGLIGIBLE * accuracy * scale
        moved_cells, fresh, before = changed[kept], fresh[kept], before[kept]
    else:
        whole = fine_multipoles(segments, cell_start, lattice, order)
        fresh = whole.reshape(n * n, *whole.shape[2:])
        largest, sizes = change_sizes(fresh, cells.fine_base.reshape(fresh.shape))
        if cells.patched_cells is not None:
            sizes[cells.patched_cells] = largest_part(fresh[cells.patched_cells] - cells.patched_fine, axis=(1, 2))
        moved_cells = np.flatnonzero(sizes > NEGLIGIBLE * accuracy * max(largest, 1e-300))
        fresh, before = fresh[moved_cells], cells.fine_of(moved_cells)
    delta = fresh - before
    moved = np.zeros(n * n, bool)
    moved[moved_cells] = True
    moved = moved.reshape(n, n)
    if not len(moved_cells):
        return replace(cells, segments=segments, cell_start=cell_start), np.zeros((n, n)), moved
    orders = uniform_orders(lattice.levels, order) if cells.orders is None else cells.orders
    sources = level_sources(delta, np.arange(len(moved_cells)), moved_cells, lattice, orders)
    centres = _centres_for(lattice)
    local, local_change = downward_onto(sources, lattice, orders, cells.local, centres=centres)
    if only_moved:
        patched = _patched(cells, moved_cells, before + delta)
    else:  # into the pages P2M has touched
        np.copyto(whole, cells.fine_base)
        rows = whole.reshape(n * n, *whole.shape[2:])
        if cells.patched_cells is not None:
            rows[cells.patched_cells] = cells.patched_fine
        rows[moved_cells] = before + delta
        patched = replace(cells, fine_base=whole, patched_cells=None, patched_fine=None)
    return (replace(patched, segments=segments, cell_start=cell_start, local=local, centres=centres), local_change,
            moved)


#: A patch of more than this share of the fine cells is applied (a copy of the whole array).
PATCH_SHARE = 1 / 16


def _patched(cells: Cells, moved: np.ndarray, values: np.ndarray) -> Cells:
    """``cells`` with the multipoles ``values`` at the fine cells ``moved`` (flat, sorted), as a patch."""
    if cells.patched_cells is None:
        rows, fine = moved, values
    else:
        rows = np.union1d(cells.patched_cells, moved)
        fine = np.empty((len(rows),) + values.shape[1:], values.dtype)
        fine[np.searchsorted(rows, cells.patched_cells)] = cells.patched_fine
        fine[np.searchsorted(rows, moved)] = values
    patched = replace(cells, patched_cells=rows, patched_fine=fine)
    if len(rows) <= PATCH_SHARE * cells.fine_base.shape[0] * cells.fine_base.shape[1]:
        return patched
    return replace(cells, fine_base=patched.fine, patched_cells=None, patched_fine=None)


def propagated_reference(cells: Cells, solved: Segments, lattice: Lattice, order: int, accuracy: float,
                         only_moved: bool = False) -> tuple[Cells, np.ndarray, np.ndarray]:
    """``propagated`` with whole arrays: the change of every fine cell, the plain passes of it (``downward_pass`` of
    ``coarser_multipoles``) and sums of arrays."""
    segments, cell_start = sort_into_cells(solved, lattice)
    if only_moved:
        n = lattice.cells_per_side
        changed = changed_runs(cells.segments, cells.cell_start, segments, cell_start)
        fresh = cells.fine.copy()
        fresh.reshape(n * n, *fresh.shape[2:])[changed] = fine_multipoles(segments, cell_start, lattice, order, changed)
    else:
        fresh = fine_multipoles(segments, cell_start, lattice, order)
    delta = fresh - cells.fine
    scale = max(largest_part(fresh), 1e-300)
    moved = largest_part(delta, axis=(2, 3)) > NEGLIGIBLE * accuracy * scale
    delta[~moved] = 0.0
    local_change = downward_pass(coarser_multipoles(delta, order), lattice, order, cells.orders)
    local_change = local_change[..., : cells.local.shape[-1]]  # zero past the pixels' terms with chosen orders
    new = Cells(segments, cell_start, cells.fine + delta, cells.local + local_change, cells.orders)
    return new, largest_part(local_change, axis=(2, 3)), moved


def _centres_for(lattice: Lattice) -> np.ndarray:
    """An array for ``Cells.centres`` of ``lattice``, for the downward pass to fill."""
    return np.empty((lattice.cells_per_side, lattice.cells_per_side, 3))


def _local_terms(order: int, pixel_order: int | None) -> int:
    """Terms of the fine local expansions ``Cells`` keeps for propagation ``order`` and ``pixel_order``."""
    return order + 1 if pixel_order is None else min(pixel_order, order) + 1


#: Saved segments count as the document's when their ends lie this close, relative to the lattice's side,
#: and their colours this close.
SAME_PLACE = 1e-10
SAME_COLOR = 1e-12


def saved_unknowns(boundary: Segments, lattice: Lattice, saved) -> np.ndarray | None:
    """The unknowns of ``boundary`` (in its order) that ``saved`` (a ``Representation`` of it) holds.

    None when ``saved``'s segments are not ``boundary``'s sorted by cell
    (another document, other settings, or a damaged file).
    """
    if len(saved.segments) != len(boundary):
        return None
    order, _ = cell_order(boundary, lattice)
    ordered, theirs = boundary.take(order), saved.segments
    curve = ~ordered.on_border
    # Not bit for bit: flattening on another machine or numpy release may differ in the last digits.
    near = SAME_PLACE * max(1.0, lattice.side)
    same = (np.array_equal(ordered.on_border, theirs.on_border)
            and all(np.allclose(getattr(ordered, name), getattr(theirs, name), rtol=0, atol=near) for name in "pq")
            and np.allclose(ordered.mean, theirs.mean, rtol=0, atol=SAME_COLOR)
            and np.allclose(ordered.jump[curve], theirs.jump[curve], rtol=0, atol=SAME_COLOR))
    if not same:
        return None
    unknowns = np.empty_like(ordered.flux)
    unknowns[order] = theirs.unknowns()
    return unknowns


def largest_part(values: np.ndarray, axis=None) -> np.ndarray | float:
    """Largest absolute real or imaginary part of complex ``values`` (over ``axis``): a cheap size.

    From the largest and smallest parts, so that no array of absolute values is made.
    """
    parts = values.view(np.float64)
    largest = np.maximum(parts.max(axis=axis, initial=0.0), -parts.min(axis=axis, initial=0.0))
    return largest if axis is not None else float(largest)


def change_sizes(fresh: np.ndarray, before: np.ndarray) -> tuple[float, np.ndarray]:
    """``largest_part(fresh)`` and ``largest_part(fresh - before)`` of each row, in one pass without the
    difference as an array (``fresh``, ``before``: ``(cells, channels, terms)`` complex)."""
    sizes = np.empty(len(fresh))
    largest = _change_sizes(np.ascontiguousarray(fresh).view(np.float64).reshape(len(fresh), -1),
                            np.ascontiguousarray(before).view(np.float64).reshape(len(before), -1), sizes)
    return float(largest), sizes


@numba.njit(cache=True)
def _change_sizes(fresh, before, sizes):
    largest = 0.0
    for row in range(fresh.shape[0]):
        size = 0.0
        for j in range(fresh.shape[1]):
            largest = max(largest, abs(fresh[row, j]))
            size = max(size, abs(fresh[row, j] - before[row, j]))
        sizes[row] = size
    return largest
