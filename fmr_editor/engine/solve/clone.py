"""Exact seamless (Poisson) cloning on the boundary representation (docs/design.md section 6, Perez et al. 2003).

A region ``Omega`` of a source image (its solved segments, field ``g``) is
placed into a target (field ``f_t``) by a similarity.  The result is ``f_t``
outside ``Omega`` and ``g + h`` inside, ``h`` harmonic with ``h = f_t - g``
on the boundary ``Gamma``.  The clone layer that gives it is the source
segments inside ``Omega`` (clipped at ``Gamma``; ``C`` kept, ``E`` divided
by the scale) plus ``Gamma`` itself, traversed with ``Omega`` on its left,
carrying ``C = f_t`` and an ``E`` from one dense solve on ``Gamma``'s
segments: collocation at their midpoints, where the mean of both sides is
``f_t / 2``, plus zero total flux (one extra unknown constant).  Its field
is ``g + h`` inside and exactly 0 outside, so the layer is composed through
the indicator of ``Omega``.

The system is assembled and factorised in source pixels (``ClonedRegion``),
once for every similarity: rotating or mirroring (with the segments
reversed) keeps both layers' matrices; scaling by ``s`` keeps the double
layer and makes the single layer ``s S + s ln(s) / 2pi * ones lengths^T``,
whose rank-one part the extra constant absorbs, as it absorbs the constant
``ln(s) / 2pi * total flux`` by which scaling shifts the copied segments'
sum at ``Gamma``.  So ``E`` in target pixels is the source-pixel solution
divided by ``s``.  ``Gamma`` is cut into pieces of ``boundary_spacing``
source pixels, which moves with the scale in steps only: every placement
within a step reuses the factorisation, and any placement gives what a
fresh build of it gives.  A placement that the canvas edge cuts changes the
region's shape and is factorised anew.  The paper instead sets
``C = f_t - g``, ``E = 0`` and solves nothing (an approximation; the tests
hold both to a raster oracle).
"""

from __future__ import annotations

import math
from concurrent.futures import Future
from dataclasses import replace
from functools import cached_property

import numpy as np
import scipy.linalg
import shapely

from ...model.clone import Similarity, region_on_canvas
from ..fmm.lattice import dilated
from ..geometry.segments import Segments, concatenate
from ..kernels.segment_sums import direct_sum, pair_matrices
from ..threads import factorisation_threads, started

#: Steps per octave of scale that share one discretisation of ``Gamma`` (``boundary_spacing``).
SCALE_STEPS = 8


def clipped_to(segments: Segments, polygon: np.ndarray) -> Segments:
    """The parts of ``segments`` inside the simple ``polygon`` ``(k, 2)`` (its edges cut them)."""
    a = np.asarray(polygon, dtype=np.float64)
    low, high = a.min(axis=0), a.max(axis=0)
    boxed = np.flatnonzero(((np.minimum(segments.p, segments.q) <= high)
                            & (np.maximum(segments.p, segments.q) >= low)).all(axis=1))  # others: outside its box
    p, q = segments.p[boxed], segments.q[boxed]
    crossing = np.flatnonzero(_near_edges(p, q, a)) if len(boxed) else boxed  # others: wholly inside or outside
    cut_owner, t0, t1 = _edge_cuts(p[crossing], q[crossing], a)
    whole = np.setdiff1d(np.arange(len(boxed)), crossing, assume_unique=True)
    owner = np.concatenate([whole, crossing[cut_owner]])
    t0, t1 = np.concatenate([np.zeros(len(whole)), t0]), np.concatenate([np.ones(len(whole)), t1])
    order = np.lexsort((t0, owner))
    owner, t0, t1 = owner[order], t0[order], t1[order]
    mid = p[owner] + (0.5 * (t0 + t1))[:, None] * (q - p)[owner]
    inside = shapely.contains_xy(shapely.Polygon(a), mid[:, 0], mid[:, 1])
    return segments.split(boxed[owner[inside]], t0[inside], t1[inside])


def _near_edges(p: np.ndarray, q: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """True for the segments ``p -> q`` that may meet an edge of ``polygon`` (all that do, and some others).

    On a grid of cells as large as the longest segment, the cells within two
    of an edge hold every segment that meets it: the meeting point lies in a
    cell next to a sample of the edge (taken every half cell), an end of the
    segment within one cell of that point.
    """
    size = max(float(np.hypot(*(q - p).T).max()), 1e-9)
    low = polygon.min(axis=0) - 3 * size
    shape = np.ceil((polygon.max(axis=0) + 3 * size - low) / size).astype(int) + 1
    edge = np.roll(polygon, -1, axis=0) - polygon
    steps = np.ceil(np.hypot(*edge.T) / (0.5 * size)).astype(int) + 1
    along = np.arange(steps.sum()) - np.repeat(np.cumsum(steps) - steps, steps)
    samples = np.repeat(polygon, steps, axis=0) + (along / np.repeat(steps - 1, steps))[:, None] * np.repeat(
        edge, steps, axis=0)
    near = np.zeros(shape, bool)
    cells = ((samples - low) // size).astype(int)
    near[cells[:, 0], cells[:, 1]] = True
    near = dilated(dilated(near))
    ends = [np.clip(((x - low) // size).astype(int), 0, shape - 1) for x in (p, q)]
    return near[ends[0][:, 0], ends[0][:, 1]] | near[ends[1][:, 0], ends[1][:, 1]]


def _edge_cuts(p: np.ndarray, q: np.ndarray, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces ``(owner, t0, t1)`` the edges of ``polygon`` cut segments ``p -> q`` into (parameters along them)."""
    e = np.roll(polygon, -1, axis=0) - polygon
    d = q - p
    w = polygon[None, :, :] - p[:, None, :]
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / denom
        u = (w[..., 0] * d[:, None, 1] - w[..., 1] * d[:, None, 0]) / denom
    cuts = np.where((denom != 0) & (t > 0) & (t < 1) & (u >= 0) & (u <= 1), t, 2.0)
    ends = np.sort(np.concatenate([np.zeros((len(p), 1)), cuts, np.ones((len(p), 1))], axis=1), axis=1)
    t0, t1 = ends[:, :-1], ends[:, 1:]
    owner, piece = np.nonzero((t1 <= 1.0) & (t1 > t0))
    return owner, t0[owner, piece], t1[owner, piece]


def boundary(polygon: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """``Gamma``: the polygon's edges cut into pieces of at most ``spacing``, with the inside on their left.

    The left is the side of ``n = (t_y, -t_x)``, the engine's normal (docs/design.md section 1).
    """
    a = np.asarray(polygon, dtype=np.float64)
    x, y = a[:, 0], a[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0:  # shoelace in y-down pixels: n points outward
        a = a[::-1]
    b = np.roll(a, -1, axis=0)
    counts = np.maximum(np.ceil(np.hypot(*(b - a).T) / spacing).astype(int), 1)
    edge = np.repeat(np.arange(len(a)), counts)
    step = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    f0, f1 = step / counts[edge], (step + 1) / counts[edge]
    d = (b - a)[edge]
    return a[edge] + f0[:, None] * d, a[edge] + f1[:, None] * d


def boundary_spacing(spacing: float, scale: float) -> float:
    """Length in source pixels of ``Gamma``'s pieces for ``spacing`` target pixels at ``scale``.

    The scale is rounded up to a step of ``2^(1 / SCALE_STEPS)``: every scale
    within a step shares one discretisation (and its factorisation), and the
    pieces are between ``2^(-1 / SCALE_STEPS)`` and 1 times ``spacing`` long
    in the target.
    """
    return spacing / 2.0 ** (math.ceil(SCALE_STEPS * math.log2(scale)) / SCALE_STEPS)


class ClonedRegion:
    """A region of a source image in source pixels: what every placement of a clone of it shares.

    The boundary system is factorised on a thread of its own
    (``threads.started``) while the copied segments are clipped and, by the
    caller, expanded into cells; ``flux`` waits for it.  On 2 cores that
    hides most of the dense LU (64 ms for 1,481 unknowns) behind the rest
    of a paste.

    Parameters
    ----------
    source : Segments
        The source image's solved segments (``E`` and ``C`` known), curves and border alike.
    region : numpy.ndarray
        ``(k, 2)`` a simple polygon in source pixels.
    spacing : float
        Length of ``Gamma``'s pieces in source pixels.

    Attributes
    ----------
    copied : Segments
        The source segments inside the region, clipped at its boundary.
    gamma_p, gamma_q : numpy.ndarray
        ``(n, 2)`` ``Gamma``'s pieces, the region on their left.
    """

    def __init__(self, source: Segments, region: np.ndarray, spacing: float) -> None:
        self.source, self.region, self.spacing = source, np.asarray(region, dtype=np.float64), spacing
        gp, gq = self.gamma_p, self.gamma_q = boundary(self.region, spacing)
        n = len(gp)
        system = np.empty((n + 1, n + 1))
        _, double = pair_matrices(0.5 * (gp + gq), gp, gq, single=system[:n])  # S assembled where it lies
        double[np.arange(n), np.arange(n)] = 0.0  # a principal value: rounding must not put the midpoint to a side
        system[:n, n], system[n, :n], system[n, n] = 1.0, np.hypot(*(gq - gp).T), 0.0
        self._double = double
        self._factorising = started(lambda: _factorised(system))  # while the copied segments are clipped and expanded
        self.copied = clipped_to(source, self.region)
        self.copied_flux = (self.copied.flux * self.copied.lengths[:, None]).sum(axis=0)

    @property
    def factorising(self) -> Future:
        """The LU factorisation of the boundary system, made on a thread of its own."""
        return self._factorising

    @property
    def _factors(self) -> tuple[np.ndarray, np.ndarray]:
        """The LU factorisation of the boundary system (waited for)."""
        return self._factorising.result()

    def fits(self, source: Segments, region: np.ndarray, spacing: float) -> bool:
        """True when this is the region ``region`` of ``source`` cut at ``spacing``."""
        return source is self.source and spacing == self.spacing and np.array_equal(region, self.region)

    @cached_property
    def copied_at_gamma(self) -> np.ndarray:
        """The copied segments' sum at ``Gamma``'s midpoints, ``(n, 3)`` (a direct sum, made when first asked for)."""
        copies = self.copied
        return direct_sum(0.5 * (self.gamma_p + self.gamma_q), copies.p, copies.q, copies.flux, copies.jump)

    def flux(self, target: np.ndarray, copied_at_gamma: np.ndarray) -> np.ndarray:
        """``E`` on ``Gamma`` in source pixels (``s`` times a placement's) for the colours ``target (n, 3)``.

        ``copied_at_gamma`` is the copied segments' sum at the midpoints, in
        source pixels or in any placement's (they differ by a constant).
        """
        n = len(self.gamma_p)
        rhs = np.empty((n + 1, 3))
        rhs[:n] = 0.5 * target + self._double @ target - copied_at_gamma
        rhs[n] = -self.copied_flux
        return scipy.linalg.lu_solve(self._factors, rhs, trans=1, check_finite=False)[:n]  # finite: made here


def _factorised(system: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The LU factors of ``system``'s transpose (solved with ``trans=1``): in Fortran order, it is factorised
    where it lies, where ``system`` itself would be copied first (11 ms less for 1,481 unknowns, with the
    assembly in place)."""
    with factorisation_threads(len(system)):
        return scipy.linalg.lu_factor(system.T, overwrite_a=True)


class SeamlessClone:
    """A region of a source image placed by a similarity, ready to be blended seamlessly into targets.

    Parameters
    ----------
    source : Segments
        The source image's solved segments (``E`` and ``C`` known), curves and border alike.
    region : numpy.ndarray
        ``(k, 2)`` a simple polygon in source pixels.
    similarity : Similarity
        Where the region goes in the target.
    spacing : float
        Length of ``Gamma``'s segments in target pixels (at most; see ``boundary_spacing``).
    canvas : tuple of float, optional
        The target's ``(width, height)``: the placed region is cut to it, so that
        the clone also blends into the target along the canvas edge.
    kept : tuple of ClonedRegion
        Regions made for other placements: one that fits this one is used (its factorisation kept).

    Raises
    ------
    ValueError
        For a region that is not a simple polygon of positive area, or that
        lands wholly outside the canvas or is split in two by its edge.
    """

    def __init__(self, source: Segments, region: np.ndarray, similarity: Similarity = Similarity(),
                 spacing: float = 1.0, canvas: tuple[float, float] | None = None,
                 kept: tuple[ClonedRegion, ...] = ()) -> None:
        self._source, self._region = source, np.asarray(region, dtype=np.float64)
        self.similarity, self.spacing, self.canvas = similarity, spacing, canvas
        placed = similarity.apply(self._region)
        on_canvas = region_on_canvas(placed, *(canvas or (None, None)))
        self.cut = on_canvas is not placed  # the canvas edge took a part of the region: its shape is this placement's
        region = similarity.inverse(on_canvas) if self.cut else self._region
        source_spacing = boundary_spacing(spacing, similarity.scale)
        fitting = [cloned for cloned in kept if cloned.fits(source, region, source_spacing)]
        self.cloned = cloned = fitting[0] if fitting else ClonedRegion(source, region, source_spacing)
        copied = cloned.copied
        p, q = similarity.apply(copied.p), similarity.apply(copied.q)
        gp, gq = similarity.apply(cloned.gamma_p), similarity.apply(cloned.gamma_q)
        if similarity.mirror:  # a mirror swaps left and right: reversed, each segment keeps its C and E
            p, q, gp, gq = q, p, gq, gp
        self.copied = replace(copied, p=p, q=q, flux=copied.flux / similarity.scale)
        self.gamma_p, self.gamma_q = gp, gq

    @property
    def midpoints(self) -> np.ndarray:
        """Where the target's field is needed: ``Gamma``'s segment midpoints, ``(n, 2)``."""
        return 0.5 * (self.gamma_p + self.gamma_q)

    @property
    def region(self) -> np.ndarray:
        """``Omega`` in the target: ``Gamma``'s vertices, ``(n, 2)``."""
        return self.gamma_p

    @property
    def _factors(self):
        """The factorisation of the boundary system (shared by the placements of one ``ClonedRegion``)."""
        return self.cloned._factors

    def gamma(self, target: np.ndarray, copied_at_gamma: np.ndarray | None = None) -> Segments:
        """``Gamma``'s segments with ``C = target (n, 3)`` (the target's colours at ``midpoints``) and ``E`` solved.

        ``copied_at_gamma`` is the copied segments' sum at ``midpoints``
        (``cloning`` reads it from their expansions); by default a direct sum.
        With diffusion points copied into the layer as well, ``target`` is the
        target's colours minus the points' sum there (``cloning.clone_layer``):
        the segments then make the rest, and are 0 outside as without points.
        """
        target = np.asarray(target, dtype=np.float64)
        if copied_at_gamma is None:
            copied_at_gamma = self.cloned.copied_at_gamma
        flux = self.cloned.flux(target, copied_at_gamma) / self.similarity.scale
        n = len(self.gamma_p)
        return Segments(self.gamma_p, self.gamma_q, target, np.zeros((n, 3)), np.zeros(n, bool), flux)

    def segments(self, target: np.ndarray, copied_at_gamma: np.ndarray | None = None) -> Segments:
        """The clone layer's segments: the copied ones, then ``gamma(target, copied_at_gamma)``."""
        return concatenate([self.copied, self.gamma(target, copied_at_gamma)])

    def placed(self, similarity: Similarity) -> SeamlessClone:
        """The same region placed by ``similarity`` instead: the factorisation is kept unless the scale leaves
        its step of ``boundary_spacing`` or the canvas edge cuts the region."""
        return SeamlessClone(self._source, self._region, similarity, self.spacing, self.canvas, (self.cloned,))

    def moved(self, dx: float, dy: float) -> SeamlessClone:
        """The same clone ``(dx, dy)`` further."""
        return self.placed(self.similarity.moved(dx, dy))


def paper_segments(clone: SeamlessClone, target: np.ndarray, source_at_gamma: np.ndarray) -> Segments:
    """The paper's approximation (section 6.1): ``Gamma`` with ``C = f_t - g``, ``E = 0``, no solve, for contrast.

    Its field is added to ``g`` inside the region (the source's whole field, not the copied segments').
    """
    n = len(clone.gamma_p)
    zeros = np.zeros((n, 3))
    return Segments(clone.gamma_p, clone.gamma_q, np.asarray(target) - source_at_gamma, zeros, np.zeros(n, bool),
                    zeros)
