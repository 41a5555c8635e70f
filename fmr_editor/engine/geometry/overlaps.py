"""Curve segments lying on top of each other: the later segment wins.

Real files contain curves that retrace themselves (control points going back
and forth along a line) or lie on top of other curves, and curves that leave
one point along one tangent run side by side, a hair apart, for a while.  Two
segments within ``COINCIDENT_DISTANCE`` of each other along a stretch
prescribe two sets of colours there and make the boundary-element system
singular or nearly so (identical or nearly identical collocation rows and
columns).  As when curves are painted in order into a raster, the segment that
comes later in the document (a later curve, or later along the same curve)
keeps the stretch; earlier ones lose it.  Segments that merely cross (their
directions more than ``MAX_SINE`` apart) keep their crossings.

The search costs about linear time whatever the geometry: identical segments
(a control-point set repeated 300 times) are grouped first and only the last
of each group looks for other overlaps; the others pair with segments of
nearby directions only (``_candidates``).  ``reference_pairs`` is the plain
search (shapely over every segment) the tests compare with.
"""

from __future__ import annotations

import numpy as np
import shapely

from .segments import Segments

#: Distance in pixels within which two segments of nearly the same direction coincide: a stretch of the earlier
#: one this near the later one's line (and beside it) is covered.  A hundredth of a pixel changes no picture;
#: nearer curves with different colours (1e-5 px, as two curves leaving a point along one tangent) made systems
#: with condition numbers of 1e13 that no preconditioner could solve.
COINCIDENT_DISTANCE = 1e-2
#: Largest sine of the angle between two segments that can cover one another.
MAX_SINE = 0.1
#: Buckets of line direction (radians; wider than the angle ``MAX_SINE`` allows) and of offset from the canvas
#: centre (pixels) for ``_candidates``: two segments that may cover one another lie in neighbouring buckets.
ANGLE_BUCKET, OFFSET_BUCKET = 0.11, 4.0


def overlapping_pairs(segments: Segments, tolerance: float = COINCIDENT_DISTANCE):
    """Pairs ``(earlier, later)`` of segments where the later covers a stretch of the earlier.

    Returns
    -------
    earlier, later : numpy.ndarray
        Segment indices, ``earlier < later``.
    start, end : numpy.ndarray
        The shared stretch as parameters ``0 <= start < end <= 1`` along ``earlier``.
    """
    twin_of = last_twins(segments)
    searched = twin_of == np.arange(len(segments))
    if tolerance <= COINCIDENT_DISTANCE:
        chosen = np.intersect1d(_candidates(segments), np.flatnonzero(searched))
    else:
        chosen = np.flatnonzero(searched)
    # The pairs of an STRtree query for dwithin (within_pairs), 1.5-2x faster (lady_bug, roses): the grown boxes
    # that meet, then shared_stretches' cheap tests, and GEOS's dwithin last, on the few pairs left.
    low, high = _boxes(segments, chosen)
    grown = shapely.box(*(low - tolerance).T, *(high + tolerance).T)
    earlier, later = shapely.STRtree(segment_lines(segments, chosen)).query(grown)
    forward = earlier < later
    earlier, later = chosen[earlier[forward]], chosen[later[forward]]
    earlier, later, start, end = shared_stretches(segments, earlier, later, tolerance)
    within = dwithin_prepared(segments, earlier, later, tolerance)
    repeated = np.flatnonzero(~searched)  # wholly covered by their last twin
    found = shared_stretches(segments, repeated, twin_of[repeated], tolerance)
    return tuple(np.concatenate([a[within], b]) for a, b in zip((earlier, later, start, end), found))


def _boxes(segments: Segments, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners ``(len(rows), 2)`` of the bounding boxes of the segments ``rows``."""
    p, q = segments.p[rows], segments.q[rows]
    return np.minimum(p, q), np.maximum(p, q)


def segment_lines(segments: Segments, rows: np.ndarray) -> np.ndarray:
    """Shapely line strings of the segments ``rows``."""
    return shapely.linestrings(np.stack([segments.p[rows], segments.q[rows]], axis=1))


def dwithin_prepared(segments: Segments, earlier: np.ndarray, later: np.ndarray, tolerance: float) -> np.ndarray:
    """Whether GEOS's prepared ``dwithin`` of ``earlier`` accepts ``later``, as an STRtree query runs it."""
    first = segment_lines(segments, earlier)
    shapely.prepare(first)
    return shapely.dwithin(first, segment_lines(segments, later), tolerance)


def within_pairs(segments: Segments, earlier: np.ndarray, later: np.ndarray, tolerance: float):
    """The pairs an STRtree query for ``dwithin`` keeps: the box of ``earlier`` grown by ``tolerance`` meets
    ``later``'s, and GEOS's prepared ``dwithin`` of ``earlier`` accepts ``later``."""
    (low_e, high_e), (low_l, high_l) = _boxes(segments, earlier), _boxes(segments, later)
    boxes = np.all((low_l <= high_e + tolerance) & (high_l >= low_e - tolerance), axis=1)
    earlier, later = earlier[boxes], later[boxes]
    within = dwithin_prepared(segments, earlier, later, tolerance)
    return earlier[within], later[within]


def last_twins(segments: Segments) -> np.ndarray:
    """For each segment, the index of the last segment with the same end points (either way round)."""
    if len(segments) == 0:
        return np.zeros(0, np.int64)
    ends = np.concatenate([segments.p, segments.q], axis=1)
    swap = (segments.q[:, 0] < segments.p[:, 0]) | ((segments.q[:, 0] == segments.p[:, 0])
                                                   & (segments.q[:, 1] < segments.p[:, 1]))
    ends[swap] = ends[swap][:, [2, 3, 0, 1]]
    order = np.lexsort(ends.T[::-1])  # stable: each group of equal rows ends with its last segment
    ordered = ends[order]
    starts = np.ones(len(order), bool)
    starts[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    last = order[np.append(np.flatnonzero(starts)[1:], len(order)) - 1]
    out = np.empty(len(order), np.int64)
    out[order] = last[np.cumsum(starts) - 1]
    return out


def _candidates(segments: Segments) -> np.ndarray:
    """Indices of the segments that may cover or be covered by another: a filter before shapely.

    Each segment's line is put in a bucket of direction and offset; a
    segment whose bucket or a neighbouring one holds another segment is kept.
    """
    d = segments.q - segments.p
    theta = np.mod(np.arctan2(d[:, 1], d[:, 0]), np.pi)
    centre = segments.p.mean(axis=0) if len(segments) else np.zeros(2)
    offset = np.cos(theta) * (segments.p[:, 1] - centre[1]) - np.sin(theta) * (segments.p[:, 0] - centre[0])
    index = np.arange(len(segments))
    # a direction just below pi is the same line as one just above 0, with the normal (and offset) flipped
    wraps = theta > np.pi - 2 * ANGLE_BUCKET
    theta = np.concatenate([theta, theta[wraps] - np.pi])
    offset = np.concatenate([offset, -offset[wraps]])
    index = np.concatenate([index, index[wraps]])
    reach = float(np.abs(np.concatenate([segments.p, segments.q]) - centre).max(initial=0.0)) * np.sqrt(2)
    bucket = max(OFFSET_BUCKET, 2 * ANGLE_BUCKET * reach)
    keys = np.stack([np.floor(theta / ANGLE_BUCKET), np.floor(offset / bucket)], axis=1).astype(np.int64)
    flat = keys[:, 0] * (1 << 32) + keys[:, 1]
    occupied, counts = np.unique(flat, return_counts=True)
    crowded = np.zeros(len(index), bool)
    for da in (-1, 0, 1):
        for dc in (-1, 0, 1):
            neighbour = flat + da * (1 << 32) + dc
            at = np.clip(np.searchsorted(occupied, neighbour), 0, max(len(occupied) - 1, 0))
            found = np.where(occupied[at] == neighbour, counts[at], 0) if len(occupied) else np.zeros(len(flat), int)
            crowded |= found - (da == 0 and dc == 0) > 0
    return np.unique(index[crowded])


def reference_pairs(segments: Segments, tolerance: float = COINCIDENT_DISTANCE):
    """``overlapping_pairs`` by the plain search: every segment against every other near it (shapely)."""
    lines = shapely.linestrings(np.stack([segments.p, segments.q], axis=1))
    earlier, later = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tolerance)
    forward = earlier < later
    return shared_stretches(segments, earlier[forward], later[forward], tolerance)


def shared_stretches(segments: Segments, earlier: np.ndarray, later: np.ndarray, tolerance: float):
    """The pairs of candidates ``earlier < later`` where the later covers a stretch of the earlier, with the stretch
    along ``earlier``: its points within ``tolerance`` of the later's line and beside the later, the two at most
    ``MAX_SINE`` apart in direction, the stretch longer than ``tolerance``."""
    tiny = np.finfo(float).tiny
    origin = segments.p[earlier]
    d = segments.q[earlier] - origin  # of these rows only: the search after an edit looks at a few
    length = np.hypot(d[:, 0], d[:, 1])
    t = d / np.maximum(length[:, None], tiny)
    base = segments.p[later]
    d_later = segments.q[later] - base
    t_later = d_later / np.maximum(np.hypot(d_later[:, 0], d_later[:, 1])[:, None], tiny)

    def across_later(points):  # signed distances from the later's line
        return (points[:, 0] - base[:, 0]) * t_later[:, 1] - (points[:, 1] - base[:, 1]) * t_later[:, 0]

    def along(points):  # parameters along the earlier
        return ((points - origin) * t).sum(axis=1) / np.maximum(length, tiny)

    # where along the earlier its distance to the later's line (linear in the parameter) is within tolerance
    near_start, near_end = across_later(origin), across_later(segments.q[earlier])
    slope = near_end - near_start
    parallel = np.abs(slope) <= tiny
    with np.errstate(divide="ignore", invalid="ignore"):
        low, high = (-tolerance - near_start) / slope, (tolerance - near_start) / slope
    within = np.abs(near_start) <= tolerance
    low, high = (np.where(parallel, np.where(within, 0.0, np.inf), np.minimum(low, high)),
                 np.where(parallel, np.where(within, 1.0, -np.inf), np.maximum(low, high)))
    a, b = along(segments.p[later]), along(segments.q[later])
    start = np.clip(np.maximum(np.minimum(a, b), low), 0.0, 1.0)
    end = np.clip(np.minimum(np.maximum(a, b), high), 0.0, 1.0)
    sine = np.abs(t[:, 0] * t_later[:, 1] - t[:, 1] * t_later[:, 0])
    shared = (sine <= MAX_SINE) & ((end - start) * length > tolerance)
    return earlier[shared], later[shared], start[shared], end[shared]


def drop_covered_parts(segments: Segments, tolerance: float = COINCIDENT_DISTANCE, pairs=None) -> Segments:
    """``segments`` without the stretches that a later segment covers.

    ``pairs``: ``overlapping_pairs(segments, tolerance)`` when known already.
    ``drop_covered_parts_reference`` is the plain loop it equals bit for bit.
    """
    if len(segments) < 2:
        return segments
    earlier, _, start, end = overlapping_pairs(segments, tolerance) if pairs is None else pairs
    if len(earlier) == 0:
        return segments
    return segments.split(*uncovered_parts(segments, earlier, start, end, np.arange(len(segments)), tolerance))


def uncovered_parts(segments: Segments, earlier: np.ndarray, start: np.ndarray, end: np.ndarray, rows: np.ndarray,
                    tolerance: float = COINCIDENT_DISTANCE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts ``(owner, t0, t1)`` of the segments ``rows`` (sorted) that no stretch ``[start, end]`` of a pair
    with them as ``earlier`` covers, longer than ``tolerance``, in order (``drop_covered_parts``).

    Every pair whose ``earlier`` is one of ``rows`` must be given; others are ignored.
    """
    mine = np.zeros(len(segments), bool)
    mine[rows] = True
    mine = mine[earlier]
    order = np.lexsort((start[mine], earlier[mine]))
    owner, start, end = earlier[mine][order], start[mine][order], end[mine][order]
    group_start = np.ones(len(owner), bool)
    group_start[1:] = owner[1:] != owner[:-1]
    group = np.cumsum(group_start) - 1
    # the sweep's cursor before each stretch: the largest end before it in its group, 0 at the group's start.
    # A running maximum that restarts per group: ranks of the ends, offset by group, are ordered group by group.
    by_end = np.argsort(end, kind="stable")
    rank = np.empty(len(end), np.int64)
    rank[by_end] = np.arange(len(end))
    reach = np.maximum.accumulate(group * len(end) + rank) - group * len(end)  # rank of the furthest end so far
    furthest = end[by_end[reach]]
    cursor = np.where(group_start, 0.0, np.roll(furthest, 1))
    gap = start > cursor
    last = np.append(group_start[1:], True)
    tail = last & (furthest < 1.0)
    covered = np.unique(owner)
    untouched = np.setdiff1d(rows, covered)
    owner = np.concatenate([untouched, owner[gap], owner[tail]])
    t0 = np.concatenate([np.zeros(len(untouched)), cursor[gap], furthest[tail]])
    t1 = np.concatenate([np.ones(len(untouched)), start[gap], np.ones(int(tail.sum()))])
    order = np.argsort(owner, kind="stable")  # per owner: the gaps in order, then the tail
    owner, t0, t1 = owner[order], t0[order], t1[order]
    d = segments.q[owner] - segments.p[owner]
    long_enough = np.hypot(d[:, 0], d[:, 1]) * (t1 - t0) > tolerance  # Segments.lengths, of these rows only
    return owner[long_enough], t0[long_enough], t1[long_enough]


def drop_covered_parts_reference(segments: Segments, tolerance: float = COINCIDENT_DISTANCE, pairs=None) -> Segments:
    """``drop_covered_parts`` by the plain sweep, one segment at a time."""
    if len(segments) < 2:
        return segments
    earlier, _, start, end = overlapping_pairs(segments, tolerance) if pairs is None else pairs
    if len(earlier) == 0:
        return segments
    order = np.lexsort((start, earlier))
    earlier, start, end = earlier[order], start[order], end[order]
    groups = np.flatnonzero(np.diff(earlier)) + 1
    owners, starts, ends = [], [], []
    for owner, group_start, group_end in zip(np.split(earlier, groups), np.split(start, groups), np.split(end, groups)):
        cursor = 0.0
        for covered_from, covered_to in zip(group_start, group_end):
            if covered_from > cursor:
                owners.append(owner[0]), starts.append(cursor), ends.append(covered_from)
            cursor = max(cursor, covered_to)
        if cursor < 1.0:
            owners.append(owner[0]), starts.append(cursor), ends.append(1.0)
    untouched = np.setdiff1d(np.arange(len(segments)), earlier)
    owner = np.concatenate([untouched, np.array(owners, dtype=np.int64)])
    t0 = np.concatenate([np.zeros(len(untouched)), starts])
    t1 = np.concatenate([np.ones(len(untouched)), ends])
    order = np.argsort(owner, kind="stable")
    owner, t0, t1 = owner[order], t0[order], t1[order]
    long_enough = segments.lengths[owner] * (t1 - t0) > tolerance
    return segments.split(owner[long_enough], t0[long_enough], t1[long_enough])
