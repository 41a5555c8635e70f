"""Exact seamless (Poisson) cloning on the boundary representation (DESIGN section 6, Perez et al. 2003).

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

The matrix depends on ``Gamma``'s shape only, and the copied segments move
with it: re-placing a clone (``SeamlessClone.placed``) evaluates ``f_t`` at
``Gamma``'s midpoints and back-substitutes.  The paper instead sets
``C = f_t - g``, ``E = 0`` and solves nothing (an approximation; the tests
hold both to a raster oracle).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.linalg
import shapely

from ...model.clone import Similarity, region_on_canvas
from ..geometry.segments import Segments, concatenate
from ..kernels.segment_sums import direct_sum, pair_matrices


def clipped_to(segments: Segments, polygon: np.ndarray) -> Segments:
    """The parts of ``segments`` inside the simple ``polygon`` ``(k, 2)`` (its edges cut them)."""
    a = np.asarray(polygon, dtype=np.float64)
    low, high = a.min(axis=0), a.max(axis=0)
    near = ((np.minimum(segments.p, segments.q) <= high) & (np.maximum(segments.p, segments.q) >= low)).all(axis=1)
    segments = segments.take(near)  # the others lie wholly outside the polygon's bounding box
    if len(segments) == 0:
        return segments
    e = np.roll(a, -1, axis=0) - a
    p, d = segments.p, segments.q - segments.p
    w = a[None, :, :] - p[:, None, :]
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / denom
        u = (w[..., 0] * d[:, None, 1] - w[..., 1] * d[:, None, 0]) / denom
    cuts = np.where((denom != 0) & (t > 0) & (t < 1) & (u >= 0) & (u <= 1), t, 2.0)
    ends = np.sort(np.concatenate([np.zeros((len(p), 1)), cuts, np.ones((len(p), 1))], axis=1), axis=1)
    t0, t1 = ends[:, :-1], ends[:, 1:]
    owner, piece = np.nonzero((t1 <= 1.0) & (t1 > t0))
    t0, t1 = t0[owner, piece], t1[owner, piece]
    mid = p[owner] + (0.5 * (t0 + t1))[:, None] * d[owner]
    inside = shapely.contains_xy(shapely.Polygon(a), mid[:, 0], mid[:, 1])
    return segments.split(owner[inside], t0[inside], t1[inside])


def boundary(polygon: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """``Gamma``: the polygon's edges cut into pieces of at most ``spacing``, with the inside on their left.

    The left is the side of ``n = (t_y, -t_x)``, the engine's normal (DESIGN section 3).
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


class SeamlessClone:
    """A region of a source image, ready to be placed seamlessly into targets.

    Parameters
    ----------
    source : Segments
        The source image's solved segments (``E`` and ``C`` known), curves and border alike.
    region : numpy.ndarray
        ``(k, 2)`` a simple polygon in source pixels.
    similarity : Similarity
        Where the region goes in the target.
    spacing : float
        Length of ``Gamma``'s segments in target pixels.
    canvas : tuple of float, optional
        The target's ``(width, height)``: the placed region is cut to it, so that
        the clone also blends into the target along the canvas edge.

    Raises
    ------
    ValueError
        For a region that is not a simple polygon of positive area, or that
        lands wholly outside the canvas or is split in two by its edge.
    """

    def __init__(self, source: Segments, region: np.ndarray, similarity: Similarity = Similarity(),
                 spacing: float = 1.0, canvas: tuple[float, float] | None = None) -> None:
        region = np.asarray(region, dtype=np.float64)
        placed = similarity.apply(region)
        kept = region_on_canvas(placed, *(canvas or (None, None)))
        self._cut = kept is not placed  # the canvas edge took a part of the region
        if self._cut:
            region = similarity.inverse(kept)
        self.similarity, self.canvas = similarity, canvas
        copied = clipped_to(source, region)
        gp, gq = boundary(region, spacing / similarity.scale)
        p, q = similarity.apply(copied.p), similarity.apply(copied.q)
        gp, gq = similarity.apply(gp), similarity.apply(gq)
        if similarity.mirror:  # a mirror swaps left and right: reversed, each segment keeps its C and E
            p, q, gp, gq = q, p, gq, gp
        self.copied = replace(copied, p=p, q=q, flux=copied.flux / similarity.scale)
        self.gamma_p, self.gamma_q = gp, gq
        single, double = pair_matrices(self.midpoints, gp, gq)
        n = len(gp)
        double[np.arange(n), np.arange(n)] = 0.0  # a principal value: rounding must not put the midpoint to a side
        lengths = np.hypot(*(gq - gp).T)
        system = np.zeros((n + 1, n + 1))
        system[:n, :n], system[:n, n], system[n, :n] = single, 1.0, lengths
        self._double = double
        self._factors = scipy.linalg.lu_factor(system)
        copies = self.copied
        self._copied_at_gamma = direct_sum(self.midpoints, copies.p, copies.q, copies.flux, copies.jump)
        self._copied_flux = (copies.flux * copies.lengths[:, None]).sum(axis=0)

    @property
    def midpoints(self) -> np.ndarray:
        """Where the target's field is needed: ``Gamma``'s segment midpoints, ``(n, 2)``."""
        return 0.5 * (self.gamma_p + self.gamma_q)

    @property
    def region(self) -> np.ndarray:
        """``Omega`` in the target: ``Gamma``'s vertices, ``(n, 2)``."""
        return self.gamma_p

    def segments(self, target: np.ndarray) -> Segments:
        """The clone layer's segments for the target's colours ``(n, 3)`` at ``midpoints``.

        With diffusion points copied into the layer as well, ``target`` is the
        target's colours minus the points' sum there (``cloning.clone_layer``):
        the segments then make the rest, and are 0 outside as without points.
        """
        target = np.asarray(target, dtype=np.float64)
        n = len(self.gamma_p)
        rhs = np.zeros((n + 1, 3))
        rhs[:n] = 0.5 * target + self._double @ target - self._copied_at_gamma
        rhs[n] = -self._copied_flux
        flux = scipy.linalg.lu_solve(self._factors, rhs)[:n]
        zeros = np.zeros((n, 3))
        gamma = Segments(self.gamma_p, self.gamma_q, target, zeros, np.zeros(n, bool), flux)
        return concatenate([self.copied, gamma])

    def placed(self, dx: float, dy: float) -> SeamlessClone:
        """The same clone moved by ``(dx, dy)``: its factorisation and copied sums are kept (unless the canvas
        edge cuts the region, which changes its shape)."""
        if self.canvas is not None:
            moved = self.gamma_p + np.array([dx, dy])
            w, h = self.canvas
            if moved.min() < 0 or moved[:, 0].max() > w or moved[:, 1].max() > h or self._cut:
                raise ValueError("a clone cut by the canvas edge is placed anew, not moved")
        twin = object.__new__(SeamlessClone)
        twin.__dict__.update(self.__dict__)
        shift = np.array([dx, dy])
        twin.similarity = self.similarity.moved(dx, dy)
        twin.copied = replace(self.copied, p=self.copied.p + shift, q=self.copied.q + shift)
        twin.gamma_p, twin.gamma_q = self.gamma_p + shift, self.gamma_q + shift
        return twin


def paper_segments(clone: SeamlessClone, target: np.ndarray, source_at_gamma: np.ndarray) -> Segments:
    """The paper's approximation (section 6.1): ``Gamma`` with ``C = f_t - g``, ``E = 0``, no solve, for contrast.

    Its field is added to ``g`` inside the region (the source's whole field, not the copied segments').
    """
    n = len(clone.gamma_p)
    zeros = np.zeros((n, 3))
    return Segments(clone.gamma_p, clone.gamma_q, np.asarray(target) - source_at_gamma, zeros, np.zeros(n, bool),
                    zeros)
