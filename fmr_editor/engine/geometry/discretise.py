"""Curves and the canvas border as straight segments: flatten, clip, cut at cells.

A document becomes segments in three steps: each curve is flattened into a
polyline that carries its colours (``flatten``), clipped to the canvas
(``clip_to_canvas``; where two segments overlap along a line the later one
keeps the overlap, ``overlaps``), then joined by the canvas border
(``canvas_border``, docs/design.md section 2) and cut where they cross the lattice's
cell edges (``cut_at_cells``), so that each lies in one fine cell.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...model import DiffusionCurve, Document
from .flatten import flatten_curves, stop_colors
from .overlaps import drop_covered_parts
from .segments import Segments, concatenate, empty_segments
from .splice import RowCache

#: Shortest piece ``cut_at_cells`` makes of a longer segment, in pixels.  A segment passing a hair beside a
#: lattice corner crosses both lattice lines at nearly one place; cut at both, the sliver between (6e-10 px where
#: poivron's curves, moved onto the canvas corners, crossed its centre) would carry an unknown whose nearly zero
#: column makes the system singular (issue 26).  The cut is not made: the piece reaches as far past the lattice
#: line.
MIN_PIECE = 1e-6


def clip_to_canvas(segments: Segments, width: float, height: float) -> Segments:
    """Parts of ``segments`` inside the canvas (Liang-Barsky), border lines excluded.

    Curve parts that run exactly along the canvas edge are dropped: the
    border condition owns those lines.
    """
    if np.all((segments.p > 0) & (segments.q > 0) & (segments.p < (width, height)) & (segments.q < (width, height))):
        return segments  # wholly inside, as most curves are
    d = segments.q - segments.p
    t0 = np.zeros(len(segments))
    t1 = np.ones(len(segments))
    for axis, size in ((0, width), (1, height)):
        start, delta = segments.p[:, axis], d[:, axis]
        for bound, sign in ((0.0, -1.0), (size, 1.0)):
            # inside means sign * (start + t delta - bound) <= 0
            num = sign * (bound - start)
            den = sign * delta
            with np.errstate(divide="ignore", invalid="ignore"):
                t = num / den
            entering = den < 0
            leaving = den > 0
            t0 = np.where(entering, np.maximum(t0, t), t0)
            t1 = np.where(leaving, np.minimum(t1, t), t1)
            outside_parallel = (den == 0) & (num < 0)
            t1 = np.where(outside_parallel, -1.0, t1)
    keep = np.flatnonzero(t1 - t0 > 1e-12)
    clipped = segments.split(keep, t0[keep], t1[keep])
    mid = clipped.midpoints
    along_edge = (
        ((clipped.p[:, 0] == clipped.q[:, 0]) & np.isin(mid[:, 0], (0.0, width)))
        | ((clipped.p[:, 1] == clipped.q[:, 1]) & np.isin(mid[:, 1], (0.0, height)))
    )
    return clipped.take(~along_edge)


def canvas_border(width: float, height: float, spacing: float) -> Segments:
    """The canvas edge as a closed chain with the canvas on its left.

    With y down, "canvas on the left" runs top-left, bottom-left,
    bottom-right, top-right.  Each side is split into equal parts no longer
    than ``spacing``.
    """
    corners = np.array([[0, 0], [0, height], [width, height], [width, 0], [0, 0]], float)
    chains = []
    for a, b in zip(corners[:-1], corners[1:]):
        count = max(1, int(np.ceil(np.hypot(*(b - a)) / spacing)))
        t = np.linspace(0.0, 1.0, count + 1)[:, None]
        chains.append(a + t * (b - a))
    p = np.concatenate([chain[:-1] for chain in chains])
    q = np.concatenate([chain[1:] for chain in chains])
    n = len(p)
    zeros = np.zeros((n, 3))
    return Segments(p, q, zeros, zeros.copy(), np.ones(n, bool), zeros.copy())


def cut_at_cells(segments: Segments, cell_size: float) -> Segments:
    """Split segments where they cross the lattice lines ``k * cell_size``.

    Afterwards every segment lies in one cell (up to its end points, and
    ``MIN_PIECE`` beyond where two cuts were that near).
    """
    return segments.split(*cell_cuts(segments, cell_size))


def cell_cuts(segments: Segments, cell_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces ``cut_at_cells`` makes, as ``(owner, t0, t1)``: each piece's segment and its parameters along it."""
    n = len(segments)
    owners = [np.arange(n), np.arange(n)]
    params = [np.zeros(n), np.ones(n)]
    d = segments.q - segments.p
    for axis in (0, 1):
        a = segments.p[:, axis] / cell_size
        b = segments.q[:, axis] / cell_size
        first = np.floor(np.minimum(a, b)) + 1
        last = np.ceil(np.maximum(a, b)) - 1
        count = np.maximum(last - first + 1, 0).astype(np.int64)
        owner = np.repeat(np.arange(n), count)
        line = first[owner] + (np.arange(len(owner)) - np.repeat(np.cumsum(count) - count, count))
        owners.append(owner)
        params.append((line * cell_size - segments.p[owner, axis]) / d[owner, axis])
    owner = np.concatenate(owners)
    t = np.clip(np.concatenate(params), 0.0, 1.0)
    order = np.lexsort((t, owner))
    owner, t = owner[order], t[order]
    first, last = np.ones(len(owner), bool), np.ones(len(owner), bool)
    first[1:] = last[:-1] = owner[1:] != owner[:-1]
    length = segments.lengths[owner]
    gap = np.diff(t, prepend=0.0) * length
    kept = first | last | ((gap >= MIN_PIECE) & ((1.0 - t) * length >= MIN_PIECE))
    owner, t = owner[kept], t[kept]
    pair = np.flatnonzero((owner[:-1] == owner[1:]) & (t[1:] - t[:-1] > 1e-12))
    return owner[pair], t[pair], t[pair + 1]


def from_curve(segments: Segments, curve_id: int) -> Segments:
    """``segments`` with the curve ``curve_id`` as their origin."""
    return replace(segments, origin=np.column_stack([np.full(len(segments), float(curve_id)), segments.origin[:, 1]]))


def curve_colors(segments: Segments, curve: DiffusionCurve) -> tuple[np.ndarray, np.ndarray]:
    """``jump`` and ``mean`` ``(n, 3)`` that ``curve``'s stops give ``segments`` at their origins' positions."""
    owner = np.zeros(len(segments), np.int64)
    left, right = (stop_colors([side], owner, segments.origin[:, 1]) for side in (curve.left, curve.right))
    return left - right, 0.5 * (left + right)


def with_curve_colors(segments: Segments, document: Document, curve_ids: tuple[int, ...]) -> Segments:
    """``segments`` with the colours of those from the curves ``curve_ids`` taken afresh from ``document``."""
    jump, mean = segments.jump.copy(), segments.mean.copy()
    for curve_id in curve_ids:
        mine = segments.origin[:, 0] == curve_id
        jump[mine], mean[mine] = curve_colors(segments.take(mine), document.curve(curve_id))
    return replace(segments, jump=jump, mean=mean)


def curve_segments(document: Document, tolerance: float = 0.05, max_length: float = 2.0) -> Segments:
    """The document's curves flattened and clipped to the canvas.

    Where segments overlap along a line, the later one keeps the overlap
    (``overlaps.drop_covered_parts``).

    Parameters
    ----------
    document : Document
    tolerance : float
        Chord tolerance of the flattening, in pixels.
    max_length : float
        Longest curve segment, in pixels.
    """
    flat = flatten_curves(document.curves, tolerance, max_length)
    curves = [from_curve(segments, curve.id) for segments, curve in zip(flat, document.curves)]
    clipped = clip_to_canvas(concatenate([empty_segments(), *curves]), document.width, document.height)
    return drop_covered_parts(clipped)


def boundary_segments(curves: Segments, document: Document, cell_size: float, border_spacing: float = 1.0) -> Segments:
    """Curve segments plus the canvas border, cut at the lattice's cell edges.

    Returns
    -------
    Segments
        Curve segments (``on_border`` False) and border segments, each lying
        in one fine cell.
    """
    border = canvas_border(document.width, document.height, border_spacing)
    return cut_at_cells(concatenate([curves, border]), cell_size)


class BoundaryCuts:
    """``boundary_segments`` of one document after another, cutting only the segments that changed since one of
    the last ``kept`` calls: the others' pieces are taken over, the same result bit for bit.

    Attributes
    ----------
    computed_rows : int
        Segments the last call cut.
    """

    def __init__(self, kept: int = 4) -> None:
        self._cuts = RowCache(cell_cuts, size=kept)
        self._borders: dict[tuple[float, float, float], Segments] = {}  # one object a canvas: cuts know it by it

    def __call__(self, curves: Segments, document: Document, cell_size: float, border_spacing: float = 1.0) -> Segments:
        canvas = (float(document.width), float(document.height), float(border_spacing))
        if canvas not in self._borders:
            self._borders = {canvas: canvas_border(*canvas)}
        return self._cuts([curves, self._borders[canvas]], float(cell_size))

    @property
    def computed_rows(self) -> int:
        return self._cuts.computed_rows
