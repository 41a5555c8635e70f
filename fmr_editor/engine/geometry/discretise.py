"""Curves and the canvas border as straight segments: flatten, clip, cut at cells.

A document becomes segments in three steps: each curve is flattened into a
polyline that carries its colours (``flatten_curve``), clipped to the canvas
(``clip_to_canvas``; where two segments overlap along a line the later one
keeps the overlap, ``overlaps``), then joined by the canvas border
(``canvas_border``, DESIGN section 3) and cut where they cross the lattice's
cell edges (``cut_at_cells``), so that each lies in one fine cell.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ...model import DiffusionCurve, Document
from .overlaps import drop_covered_parts
from .segments import Segments, concatenate, empty_segments


def _max_speed(pieces: np.ndarray, samples: int = 65, chunk: int = 4096) -> np.ndarray:
    """Upper bound of ``max |B'(t)|`` over each piece ``(k, 4, 2)``, within a hair of the truth.

    ``B'(t) = A t^2 + B t + C`` is quadratic, so between samples ``delta`` apart
    it strays from the straight line through them by at most ``|A| delta^2 / 4``.
    Pieces go ``chunk`` at a time: the samples of all 524,288 pieces of a
    Hilbert benchmark curve at once took 1.1 GB.
    """
    d = 3.0 * np.diff(pieces, axis=1)  # hodograph control points, (k, 3, 2)
    t = np.linspace(0.0, 1.0, samples)[:, None, None]
    speed = np.empty(len(pieces))
    for start in range(0, len(pieces), chunk):
        h = d[start:start + chunk]
        hodograph = (1 - t) ** 2 * h[:, 0] + 2 * (1 - t) * t * h[:, 1] + t**2 * h[:, 2]  # (samples, chunk, 2)
        speed[start:start + chunk] = np.hypot(hodograph[..., 0], hodograph[..., 1]).max(axis=0)
    curvature = np.hypot(*(d[:, 0] - 2 * d[:, 1] + d[:, 2]).T)  # |A|
    return speed + curvature / (4.0 * (samples - 1) ** 2)


def flatten_curve(curve: DiffusionCurve, tolerance: float, max_length: float) -> Segments:
    """Polyline approximation of ``curve`` with its colours.

    Each cubic piece is split uniformly in its parameter into enough parts
    that the chord error stays below ``tolerance`` (bound: ``max|B''| / 8n^2``)
    and no part is longer than ``max_length`` (bound: the largest speed ``|B'|``).  Colour-stop positions are added as breakpoints so that colours
    are linear within every segment and its midpoint colour is its mean.

    Parameters
    ----------
    curve : DiffusionCurve
    tolerance : float
        Largest distance between the curve and its polyline, in pixels.
    max_length : float
        Largest segment length, in pixels.

    Returns
    -------
    Segments
    """
    parts = _parts(curve.pieces(), tolerance, max_length)
    piece = np.repeat(np.arange(len(parts)), parts)
    step = np.arange(len(piece)) - np.repeat(np.cumsum(parts) - parts, parts)
    s = np.concatenate([piece + step / parts[piece], [curve.piece_count]])
    stops = [stop.position for stop in curve.left + curve.right]
    s = np.unique(np.concatenate([s, stops]))

    points = curve.point_at(s)
    middle = 0.5 * (s[:-1] + s[1:])
    left, right = curve.left_colors_at(middle), curve.right_colors_at(middle)  # as curve_colors
    keep = np.hypot(*np.diff(points, axis=0).T) > 1e-9
    n = int(keep.sum())
    return Segments(
        p=points[:-1][keep],
        q=points[1:][keep],
        jump=(left - right)[keep],
        mean=(0.5 * (left + right))[keep],
        on_border=np.zeros(n, bool),
        flux=np.zeros((n, 3)),
        origin=np.column_stack([np.full(n, -1.0), middle[keep]]),
    )


def _parts(pieces: np.ndarray, tolerance: float, max_length: float) -> np.ndarray:
    """How many parts ``flatten_curve`` splits each of the ``(k, 4, 2)`` cubic ``pieces`` into."""
    second = np.maximum(
        np.hypot(*(pieces[:, 0] - 2 * pieces[:, 1] + pieces[:, 2]).T),
        np.hypot(*(pieces[:, 1] - 2 * pieces[:, 2] + pieces[:, 3]).T),
    )
    parts = np.maximum(np.sqrt(0.75 * second / tolerance), _max_speed(pieces) / max_length)
    return np.clip(np.ceil(parts), 1, 1_000_000).astype(np.int64)


def flattened_count(curves: Sequence[DiffusionCurve], tolerance: float, max_length: float) -> int:
    """About how many segments ``flatten_curve`` makes of ``curves`` (colour stops aside), without making them:
    all the curves' pieces at once."""
    counts = np.fromiter((len(curve.control_points) for curve in curves), np.int64, len(curves))
    if not counts.size:
        return 0
    points = np.concatenate([curve.control_points for curve in curves])
    per_curve = (counts - 1) // 3
    first_piece = np.cumsum(per_curve) - per_curve
    curve_of_piece = np.repeat(np.arange(len(curves)), per_curve)
    piece_in_curve = np.arange(per_curve.sum()) - first_piece[curve_of_piece]
    first = (np.cumsum(counts) - counts)[curve_of_piece] + 3 * piece_in_curve
    return int(_parts(points[first[:, None] + np.arange(4)], tolerance, max_length).sum())


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

    Afterwards every segment lies in one cell (up to its end points).
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
    pair = np.flatnonzero((owner[:-1] == owner[1:]) & (t[1:] - t[:-1] > 1e-12))
    return owner[pair], t[pair], t[pair + 1]


def from_curve(segments: Segments, curve_id: int) -> Segments:
    """``segments`` with the curve ``curve_id`` as their origin."""
    return replace(segments, origin=np.column_stack([np.full(len(segments), float(curve_id)), segments.origin[:, 1]]))


def curve_colors(segments: Segments, curve: DiffusionCurve) -> tuple[np.ndarray, np.ndarray]:
    """``jump`` and ``mean`` ``(n, 3)`` that ``curve``'s stops give ``segments`` at their origins' positions."""
    left, right = curve.left_colors_at(segments.origin[:, 1]), curve.right_colors_at(segments.origin[:, 1])
    return left - right, 0.5 * (left + right)


def with_curve_colors(segments: Segments, document: Document, curve_ids: tuple[int, ...]) -> Segments:
    """``segments`` with the colours of those from the curves ``curve_ids`` taken afresh from ``document``."""
    jump, mean = segments.jump.copy(), segments.mean.copy()
    for curve_id in curve_ids:
        mine = segments.origin[:, 0] == curve_id
        jump[mine], mean[mine] = curve_colors(segments.take(mine), document.curve(curve_id))
    return replace(segments, jump=jump, mean=mean)


def curve_segments(
    document: Document,
    tolerance: float = 0.05,
    max_length: float = 2.0,
    flatten: Callable[[DiffusionCurve, float, float], Segments] = flatten_curve,
) -> Segments:
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
    flatten : callable
        ``flatten_curve`` or a cache in front of it.
    """
    curves = [from_curve(flatten(curve, tolerance, max_length), curve.id) for curve in document.curves]
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
