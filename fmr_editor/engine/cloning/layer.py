"""A placed seamless clone made into a layer: its image and its mask as representations, no solve of either.

The image is the clone layer's segments (the copied source segments and
``Gamma`` with its solved ``E``) plus the copied diffusion points; the mask
is the indicator of the region (``Gamma`` with ``C = 1`` and ``E = 0``).
The segments' field is 0 outside the region (up to ``Gamma``'s
discretisation), so only the cells of the region and of the 3x3 blocks
around ``Gamma`` (``region_cells``) get local expansions, those of the
whole-level passes; elsewhere the expansions are left 0 and no segment lies
in a cell's 3x3 block, so both fields are exactly 0 there, and the layer,
weighted by its mask, adds nothing.  (The image's diffusion points are
expanded on the whole lattice, as in any image.)

The FMR is linear in its sources, so the image is made in two parts on one
lattice (``layer_lattice``).  The copied segments' part (``CopiedCells``:
sorted by cell, expanded) depends on the placement only: it is kept while
the layers below change, and it gives the copied segments' sum at ``Gamma``
for the solve.  ``Gamma``'s part, image and mask as four channels of one
pass, follows the solve.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import shapely

from ...model import DiffusionPoint
from ...model.clone import Clone, Similarity, region_on_canvas
from ..composite import Composite, LayerFields
from ..fmm.far_field import far_field_at
from ..fmm.lattice import Lattice, cut_into_cells, dilated, fine_multipoles, merged
from ..fmm.orders import PassOrders, pass_orders
from ..fmm.sparse_downward import cascade, interactions, pass_levels
from ..geometry.segments import Segments
from ..kernels.segment_sums import near_sum
from ..points.field import PointField
from ..points.gauss import GaussPoints, gaussian_sum_reference
from ..raster import evaluate_points
from ..representation import CLONE_SEGMENTS_PER_CELL, Representation, Settings, choose_levels
from ..solve.clone import SeamlessClone
from ..threads import beside


def _reaching(points: tuple[DiffusionPoint, ...], similarity: Similarity,
              region: np.ndarray) -> tuple[DiffusionPoint, ...]:
    """``points`` placed by ``similarity`` (radii scaled) whose blobs reach the placed ``region`` (to ``exp(-16)``)."""
    if not points:
        return ()
    packed = GaussPoints.from_points(points)
    positions, radii = similarity.apply(packed.positions), packed.radii * similarity.scale
    near = shapely.distance(shapely.Polygon(region), shapely.points(positions)) <= 4.0 * radii
    return tuple(replace(point, position=tuple(position), radius=float(radius), id=None)
                 for point, position, radius, keep in zip(points, positions, radii, near) if keep)


def placed_points(points: tuple[DiffusionPoint, ...], clone: SeamlessClone) -> tuple[DiffusionPoint, ...]:
    """The source ``points`` placed by the clone's similarity whose blobs reach its region."""
    return _reaching(points, clone.similarity, clone.region)


def clone_points(clone: Clone, width: int, height: int) -> tuple[DiffusionPoint, ...]:
    """The diffusion points of ``clone``'s layer on a ``width x height`` canvas: its source's points placed,
    those reaching its region on the canvas."""
    return _reaching(clone.source.points, clone.similarity, region_on_canvas(clone.placed_region, width, height))


def _boundary(clone: SeamlessClone) -> Segments:
    """``Gamma``'s segments, their geometry only; ``origin[:, 0]`` numbers them (to follow them through cuts)."""
    n = len(clone.gamma_p)
    zeros = np.zeros((n, 3))
    return Segments(clone.gamma_p, clone.gamma_q, zeros, zeros, np.zeros(n, bool), zeros,
                    np.column_stack([np.arange(n, dtype=np.float64), np.full(n, np.nan)]))


def region_edges(clone: SeamlessClone) -> Segments:
    """The mask's segments: the region's polygon edges (``Gamma``'s pieces joined where they run straight on),
    white on the inside, black outside.

    With a constant jump and no flux, a straight segment's field is exact
    whatever its length, so the whole edges give the indicator of the region
    as ``Gamma``'s pieces do, with far fewer segments for the near field of
    every pixel around the boundary to sum.
    """
    p, d = clone.gamma_p, clone.gamma_q - clone.gamma_p
    before = np.roll(d, 1, axis=0)
    turn = before[:, 0] * d[:, 1] - before[:, 1] * d[:, 0]
    straight = (np.abs(turn) <= 1e-9 * np.hypot(*before.T) * np.hypot(*d.T)) & ((before * d).sum(axis=1) > 0)
    corners = np.flatnonzero(~straight) if not straight.all() else np.array([0])
    n = len(corners)
    white = np.ones((n, 3))
    return Segments(p[corners], p[np.roll(corners, -1)], white, 0.5 * white, np.zeros(n, bool), np.zeros((n, 3)))


def layer_lattice(clone: SeamlessClone, below: Composite, settings: Settings) -> Lattice:
    """The lattice of a clone layer over ``below``: chosen for its segments (``CLONE_SEGMENTS_PER_CELL``), at most
    as deep as the layers below."""
    mids = np.concatenate([clone.copied.midpoints, clone.midpoints])
    side = float(max(below.width, below.height))
    levels = settings.levels or choose_levels(mids, side, CLONE_SEGMENTS_PER_CELL)
    deepest = max((layer.image.lattice.levels for layer in below.layers), default=levels)
    return Lattice(min(levels, deepest), side)


def ring_cells(pieces: Segments, lattice: Lattice) -> np.ndarray:
    """The fine cells whose 3x3 block holds one of ``pieces`` (``Gamma`` cut at the cells), bool ``(2^L, 2^L)``."""
    n = lattice.cells_per_side
    ring = np.zeros((n, n), bool)
    at = lattice.cell_of(pieces.midpoints)
    ring[at[:, 0], at[:, 1]] = True
    return dilated(ring)


def region_cells(pieces: Segments, region: np.ndarray, lattice: Lattice) -> np.ndarray:
    """The fine cells where a clone layer's fields are not 0, bool ``(2^L, 2^L)``.

    ``pieces`` are ``Gamma``'s segments cut at the cells, ``region`` its
    vertices.  The cells whose 3x3 block holds a piece of ``Gamma`` (the
    ring) count; every other cell lies wholly inside the region or wholly
    outside it, and so does its 3x3 block (no boundary crosses it): those
    inside count.  A copied segment lies inside the region, so every cell
    whose 3x3 block holds one is among them.
    """
    cells = ring_cells(pieces, lattice)
    low, high = lattice.cell_of(region.min(axis=0)[None])[0], lattice.cell_of(region.max(axis=0)[None])[0]
    rows, columns = np.nonzero(~cells[low[0]:high[0] + 1, low[1]:high[1] + 1])  # outside its box: outside
    rows, columns = rows + low[0], columns + low[1]
    centres = lattice.cell_centres(np.stack([rows, columns], axis=1))
    cells[rows, columns] = shapely.contains_xy(shapely.Polygon(region), centres[:, 0], centres[:, 1])
    return cells


@dataclass(frozen=True, eq=False)
class CopiedCells:
    """A placed clone on a layer's lattice: its copied segments sorted by cell with their M2L, and ``Gamma``'s pieces.

    What depends on the placement only, kept while the layers below change.

    Attributes
    ----------
    lattice : Lattice
    cells : numpy.ndarray
        ``(2^L, 2^L)`` bool: where the layer's fields are not 0 (``region_cells``).
    levels : list
        ``sparse_downward.pass_levels`` of ``cells``.
    segments : Segments
        The copied segments cut at the cells, sorted by cell.
    cell_start : numpy.ndarray
    m2l : list of numpy.ndarray
        ``sparse_downward.interactions`` of the copied segments at ``levels`` (no L2L yet).
    orders : PassOrders
        The terms each translation keeps, as a build's for the pixels' degree (``orders.pass_orders``): what
        the solve reads at ``Gamma`` is what the pixels read there.
    gamma : Segments
        ``Gamma`` cut at the cells, sorted by cell: the geometry, with ``origin[:, 0]`` the segment each piece is of.
    gamma_start : numpy.ndarray
    edges : Segments
        The mask's segments (``region_edges``) cut at the cells, sorted by cell.
    edge_start : numpy.ndarray
    """

    lattice: Lattice
    cells: np.ndarray
    levels: list
    segments: Segments
    cell_start: np.ndarray
    m2l: list
    orders: PassOrders
    gamma: Segments
    gamma_start: np.ndarray
    edges: Segments
    edge_start: np.ndarray

    @classmethod
    def build(cls, clone: SeamlessClone, lattice: Lattice, settings: Settings) -> CopiedCells:
        """The cells of ``clone`` placed on ``lattice``; on one core while its boundary system is factorised on
        the other (``threads.beside``)."""
        order = settings.propagation_order
        orders = pass_orders(lattice.levels, min(settings.order, order), order)
        with beside(clone.cloned.factorising):
            gamma, gamma_start = cut_into_cells(_boundary(clone), lattice)
            cells = region_cells(gamma, clone.region, lattice)
            levels = pass_levels(cells, lattice)
            segments, cell_start = cut_into_cells(clone.copied, lattice)
            occupied = np.flatnonzero(np.diff(cell_start))
            moments = fine_multipoles(segments, cell_start, lattice, order, occupied)
            m2l = interactions(occupied, moments, lattice, order, levels, orders)
            edges, edge_start = cut_into_cells(region_edges(clone), lattice)
        return cls(lattice, cells, levels, segments, cell_start, m2l, orders, gamma, gamma_start, edges, edge_start)

    def at(self, points: np.ndarray) -> np.ndarray:
        """The copied segments' sum at ``points (m, 2)`` in ``cells``, ``(m, 3)``, as the pixels read it: near
        segments and the fine cells' expansions (L2L down to the points' cells only)."""
        lattice = self.lattice
        n = lattice.cells_per_side
        cells = lattice.cell_of(points)
        flat = cells[:, 0] * n + cells[:, 1]
        targets, local = cascade(self.m2l, self.levels, self.orders.width, np.unique(flat))
        row_of = self.levels[-1].row_of  # the cascade keeps the order of the level's rows
        far = far_field_at(local, lattice, cells, points, rows=np.searchsorted(row_of[targets], row_of[flat]))
        near = np.zeros((n, n), bool)
        near[cells[:, 0], cells[:, 1]] = True
        near = dilated(near).ravel()  # the points' 3x3 blocks: only their segments are read
        counts = np.where(near, np.diff(self.cell_start), 0)
        seg = self.segments.take(np.repeat(near, np.diff(self.cell_start)))
        start = np.concatenate([[0], np.cumsum(counts)])
        return far + near_sum(points, n, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)

    @cached_property
    def mask_local(self) -> np.ndarray:
        """The mask's local expansions ``(2^L, 2^L, 3, P + 1)``, every term: the indicator of the region is 1 inside
        it to their accuracy, so a placement that keeps a cell inside both regions changes it by rounding only
        (``LiveClone.follow``)."""
        start, lattice, order = self.edge_start, self.lattice, self.orders.width
        occupied = np.flatnonzero(np.diff(start))
        moments = fine_multipoles(self.edges, start, lattice, order, occupied)[:, :1]
        targets, local = cascade(interactions(occupied, moments, lattice, order, self.levels), self.levels, order)
        return _dense(targets, local, lattice.cells_per_side)

    def gamma_with(self, jump: np.ndarray, flux: np.ndarray) -> Segments:
        """``Gamma``'s pieces carrying ``C = jump`` and ``E = flux``, ``(n, 3)`` each by segment of ``Gamma``."""
        owner = self.gamma.origin[:, 0].astype(np.int64)
        return replace(self.gamma, jump=jump[owner], flux=flux[owner], origin=None)


def _dense(targets: np.ndarray, local: np.ndarray, n: int) -> np.ndarray:
    """``local`` ``(cells, 1 or 3, K)`` of the flat cells ``targets`` on a whole ``n x n`` level of three
    channels, zero elsewhere."""
    dense = np.zeros((n * n, 3, local.shape[-1]), complex)
    dense[targets] = local
    return dense.reshape(n, n, 3, local.shape[-1])


def _layer_fields(clone: SeamlessClone, copied: CopiedCells, target: np.ndarray, settings: Settings,
                  size: tuple[int, int], points: tuple[DiffusionPoint, ...]) -> tuple[Representation, Representation]:
    """The image and the mask of the clone layer for the colours ``target`` its segments must make at ``Gamma``."""
    lattice, order, start = copied.lattice, settings.propagation_order, copied.gamma_start
    mask_local = copied.mask_local  # needs no solve: made while the boundary system may still be factorised
    gamma = copied.gamma_with(target, clone.gamma(target, copied.at(clone.midpoints)).flux)
    occupied = np.flatnonzero(np.diff(start))
    m2l = interactions(occupied, fine_multipoles(gamma, start, lattice, order, occupied), lattice, order,
                       copied.levels, copied.orders)
    for level, mine in zip(m2l, copied.m2l):
        if level is not None:
            level += mine
    targets, local = cascade(m2l, copied.levels, order)
    n = lattice.cells_per_side
    image_segments, image_start = merged(copied.segments, copied.cell_start, gamma, start)
    field = PointField.build(tuple(points), lattice, settings.order) if points else None
    image = Representation(*size, lattice, image_segments, image_start, _dense(targets, local, n),
                           settings.order, {}, field)
    mask = Representation(*size, lattice, copied.edges, copied.edge_start, mask_local,
                          settings.order, {})
    return image, mask


def clone_layer(clone: SeamlessClone, below: Composite, settings: Settings = Settings(), layer_id: int = 0,
                points: tuple[DiffusionPoint, ...] = (), placed: tuple[DiffusionPoint, ...] | None = None,
                copied: CopiedCells | None = None) -> LayerFields:
    """The layer that puts ``clone`` seamlessly over ``below`` (its region cut to ``below``'s canvas).

    ``points`` are the source's diffusion points: those reaching the region are
    copied into the layer (placed, their radii scaled), their sum at the
    boundary taken off what the segments there must make.  ``placed`` gives
    the copied points instead (``clone_points``).  ``copied`` gives the
    copied segments' cells when they are known (``CopiedCells.build`` of this
    placement on the layer's lattice).
    """
    placed = placed_points(points, clone) if placed is None else placed
    if copied is None:
        copied = CopiedCells.build(clone, layer_lattice(clone, below, settings), settings)
    target = evaluate_points(below, clone.midpoints)
    if placed:
        packed = GaussPoints.from_points(placed)
        target = target - gaussian_sum_reference(clone.midpoints, packed.positions, packed.radii, packed.weights)
    image, mask = _layer_fields(clone, copied, target, settings, (below.width, below.height), placed)
    return LayerFields(image, mask, mask_base=0.0, id=layer_id)
