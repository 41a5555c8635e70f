"""The fast multipole representation (FMR) of a document, its settings and lattice depth.

``live.build`` makes one in four stages, each timed in
``Representation.timings``: discretise (flatten, clip, choose the lattice,
cut at cells), solve (the boundary-element system), upward (P2M, M2M) and
downward (M2L, L2L); a document with diffusion points adds a fifth, points
(their polynomials).  ``live.LiveRepresentation`` keeps one up to date.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .fmm.expansions import local_polynomials
from .fmm.lattice import Lattice
from .geometry.segments import Segments
from .kernels.fastmath import INV_TWO_PI
from .kernels.segment_sums import near_tables
from .kernels.single import error_bounds
from .points.field import PointField
from .value_bounds import scalar_bounds


@dataclass(frozen=True)
class Settings:
    """How a representation is built.

    Parameters
    ----------
    order : int
        Degree of the cell polynomials used for pixels.
    propagation_order : int
        Terms carried through the FMM passes (more than ``order``).
    levels : int or None
        Lattice depth L (``2^L`` cells per side); None chooses it from the
        segment density.
    tolerance : float
        Chord tolerance when flattening curves, in pixels.
    max_length : float
        Longest curve segment, in pixels.
    border_spacing : float
        Longest canvas-border segment, in pixels.
    """

    order: int = 8
    propagation_order: int = 16
    levels: int | None = None
    tolerance: float = 0.05
    max_length: float = 2.0
    border_spacing: float = 1.0

    def __post_init__(self) -> None:
        if not 0 <= self.order <= self.propagation_order <= 60:
            raise ValueError("need 0 <= order <= propagation_order <= 60")
        if self.levels is not None and not 2 <= self.levels <= MAX_LEVELS:
            raise ValueError(f"levels must be between 2 and {MAX_LEVELS}")


MAX_LEVELS = 11
#: Mean segments per occupied fine cell that ``choose_levels`` aims below.
SEGMENTS_PER_CELL = 6.0
#: The same for the lattice of the iterative solve's products (order 20): fewer
#: levels, more exact near-field pairs.  A product on the lattice one level
#: coarser than 24 chose, ms: at 31-39 segments a cell 24-91 against 34-114
#: (lady_bug, poivron, zephyr, fruits), at 54-86 slower (flower, glass_droplet_blur,
#: gm_grapes, dolphin, roses).
SOLVE_SEGMENTS_PER_CELL = 40.0
#: The same for a clone layer, made anew on every frame of a drag: its downward
#: pass is paid per frame (a level less is about 4x fewer cells; a drag frame of
#: roses into itself 280 -> 125 ms, near fields of about 10 segments a cell).
CLONE_SEGMENTS_PER_CELL = 12.0
#: Smallest fine cell ``choose_levels`` picks, in pixels.
MIN_CELL_SIZE = 2.0


@dataclass(frozen=True, eq=False)
class Representation:
    """A document's FMR: solved segments sorted into cells plus far-field expansions.

    Attributes
    ----------
    width, height : int
        Canvas size.
    lattice : Lattice
    segments : Segments
        Solved segments sorted by fine cell.
    cell_start : numpy.ndarray
        CSR offsets of each fine cell's segments.
    local : numpy.ndarray
        ``(2^L, 2^L, 3, K)`` complex scaled local expansions of each fine
        cell's far field (everything outside its 3x3 block), ``K > order``:
        the pixels' ``order + 1`` terms as the editor builds and opens them
        (``Cells.local``; files hold ``P + 1``, zero past the pixels').
    order : int
        Polynomial degree used for pixels.
    timings : dict
        Seconds spent in each build stage.
    points : PointField or None
        The document's diffusion points, if any.
    centres : numpy.ndarray or None
        ``(2^L, 2^L, 3)`` each fine cell's far field at its centre as the build wrote it (``Cells.centres``);
        None: taken from ``local`` when first read (``centre_values``).
    """

    width: int
    height: int
    lattice: Lattice
    segments: Segments
    cell_start: np.ndarray
    local: np.ndarray
    order: int
    timings: dict = field(default_factory=dict)
    points: PointField | None = None
    centres: np.ndarray | None = field(default=None, repr=False, compare=False)

    @cached_property
    def centre_values(self) -> np.ndarray:
        """``(2^L, 2^L, 3)`` float: each fine cell's far field at its centre, ``Re L_0 / 2 pi`` (its segments'
        alone, as ``local``), contiguous: what a raster whose samples lie on the centres reads (``raster``)."""
        if self.centres is not None:
            return self.centres
        return np.ascontiguousarray(self.local[..., 0].real) * INV_TWO_PI

    @cached_property
    def near(self) -> tuple[Segments, np.ndarray]:
        """The segments a pixel's near field sums, and each fine cell's CSR offsets into them: ``segments`` and
        ``cell_start``, or none at all where every segment's E and C are 0.  That is a field of diffusion points
        alone (a soft mask, a layer of brush dabs): its canvas border solves to 0, and its 4 (W + H) segments,
        summed at every pixel beside the border, took more than half of such a mask's time on the canvas."""
        seg = self.segments
        if len(seg.p) and not (seg.flux.any() or seg.jump.any()):
            return seg.take(np.zeros(len(seg.p), bool)), np.zeros_like(self.cell_start)
        return seg, self.cell_start

    def joined_with(self, alpha: Representation) -> tuple[np.ndarray, np.ndarray, tuple, np.ndarray]:
        """The ``near`` segments' E and C ``(m, 4)`` with those of ``alpha``'s first channel, an alpha field of the
        same segments (``composite.LayerFields.carries_alpha``), their ``near_tables`` and ``near_bounds``: what the
        raster's kernels of four channels take with the two fields' expansions.  The last ones made are kept (a
        few rows a segment), without keeping ``alpha``."""
        kept = self.__dict__.get("_joined")
        if kept is not None and kept[0]() is alpha:
            return kept[1]
        (seg, cell_start), lattice, alpha_segments = self.near, self.lattice, alpha.near[0]
        flux, jump = with_alpha(seg.flux, alpha_segments.flux), with_alpha(seg.jump, alpha_segments.jump)
        joined = (flux, jump, near_tables(seg.p, seg.q, flux, jump),
                  error_bounds(lattice.cells_per_side, lattice.cell_size, cell_start, flux, jump))
        self.__dict__["_joined"] = weakref.ref(alpha), joined  # a frozen dataclass's memo, as ``cached_property``'s
        return joined

    def scalar_bounds(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``value_bounds.scalar_bounds`` of ``weights . value``: each fine cell's centre value and how far from it
        the cell's values may get.  The last weights' are kept (a mask is drawn with its luminance each time)."""
        key = np.asarray(weights, np.float64).tobytes()
        kept = self.__dict__.get("_scalar_bounds")
        if kept is None or kept[0] != key:
            kept = self.__dict__["_scalar_bounds"] = key, scalar_bounds(self, weights)  # as ``joined_with``'s memo
        return kept[1]

    @cached_property
    def near_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """``segment_sums.near_tables`` of the ``near`` segments, kept for the point evaluations that follow (a
        live representation hands out the same ``Representation`` until it changes)."""
        seg = self.near[0]
        return near_tables(seg.p, seg.q, seg.flux, seg.jump)

    @cached_property
    def near_bounds(self) -> np.ndarray:
        """``kernels.single.error_bounds`` of the ``near`` segments: the raster's float32 near field's bound in each
        cell, kept as ``near_tables`` are."""
        (seg, cell_start), lattice = self.near, self.lattice
        return error_bounds(lattice.cells_per_side, lattice.cell_size, cell_start, seg.flux, seg.jump)

    def polynomials(self, order: int | None = None, cells: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """Cell polynomials ``c[row, column, channel, i, j]`` of ``xi^i eta^j``.

        ``(xi, eta) = ((x, y) - cell centre) / cell size`` lie in
        ``[-1/2, 1/2]``; the far field at a point is
        ``sum_ij c_ij xi^i eta^j``.  Harmonic fields fill ``i + j <= order``;
        the tensor layout leaves room for non-harmonic terms.

        Parameters
        ----------
        order : int, optional
            Degree; defaults to ``self.order``, at most the propagation order.
        cells : tuple of numpy.ndarray, optional
            ``(rows, columns)``: only these cells' polynomials, ``(m, channel, i, j)``.
        """
        order = self.order if order is None else order
        if not 0 <= order < self.local.shape[-1]:
            raise ValueError(f"order must be between 0 and {self.local.shape[-1] - 1}")
        coeffs = local_polynomials(self.local if cells is None else self.local[cells], order)
        if self.points is not None:
            point_coeffs = self.points.polynomials(order)
            coeffs += point_coeffs if cells is None else point_coeffs[cells]
        return coeffs


def with_alpha(colour: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``(m, 4)``: segments' colour values ``(m, 3)`` (E or C) and their alpha field's first channel's: a layer
    whose alpha field has its image's segments (``composite.LayerFields.carries_alpha``) as one field of four
    channels."""
    return np.concatenate([colour, alpha[:, :1]], axis=1)


def same_geometry(before: Representation, after: Representation) -> bool:
    """Whether both have the same ``near`` segments in the same cells (only their E and C may differ)."""
    (old, old_start), (new, new_start) = before.near, after.near
    return old is new or (np.array_equal(old_start, new_start) and np.array_equal(old.p, new.p)
                          and np.array_equal(old.q, new.q))


def choose_levels(curves: Segments | np.ndarray, side: float, per_cell: float = SEGMENTS_PER_CELL) -> int:
    """Lattice depth: the coarsest with at most ``per_cell`` segments per occupied cell.

    ``curves`` are the segments or their midpoints ``(n, 2)``.  Stops
    refining at cells of ``MIN_CELL_SIZE`` pixels.
    """
    mids = curves if isinstance(curves, np.ndarray) else curves.midpoints
    finest = Lattice(MAX_LEVELS, side).cell_of(mids)  # a coarser level's cells are these halved (exactly)
    for levels in range(2, MAX_LEVELS + 1):
        lattice = Lattice(levels, side)
        if lattice.cell_size / 2 < MIN_CELL_SIZE or len(mids) == 0:
            return levels
        cells = finest >> (MAX_LEVELS - levels)
        flat = cells[:, 0] * lattice.cells_per_side + cells[:, 1]
        many = lattice.cells_per_side**2 > 8 * len(flat)
        occupied = len(np.unique(flat)) if many else np.count_nonzero(np.bincount(flat))
        if len(mids) / occupied <= per_cell:
            return levels
    return MAX_LEVELS
