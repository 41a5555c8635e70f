"""Collinear overlaps between curve segments: the later segment wins.

Real files contain curves that retrace themselves (control points going back
and forth along a line) or lie on top of other curves.  Two segments covering
the same stretch of line prescribe two sets of colours there and make the
boundary-element system singular (identical collocation rows and columns).
As when curves are painted in order into a raster, the segment that comes
later in the document (a later curve, or later along the same curve) keeps
the overlap; earlier ones lose the covered part.

The search costs about linear time whatever the geometry: identical segments
(a control-point set repeated 300 times) are grouped first and only the last
of each group looks for other overlaps; the others pair with segments on
nearby lines only (buckets of direction and offset), and a search that would
still compare more than ``CANDIDATES_PER_SEGMENT`` pairs a segment is refused.
``reference_pairs`` is the plain search (shapely over every segment) the
tests compare with.
"""

from __future__ import annotations

import numpy as np
import shapely

from .segments import Segments

#: Distance in pixels under which end points count as on another segment's line.
COLLINEAR_TOLERANCE = 1e-6
#: Buckets of line direction (radians) and offset from the canvas centre (pixels) for ``_candidates``: two
#: collinear segments at least ``SHORT`` long differ by at most 2 tolerance / SHORT = 1e-3 radians in
#: direction and so, within ``reach`` pixels of the centre, by at most 1e-3 reach in offset (the bucket grows).
ANGLE_BUCKET, OFFSET_BUCKET, SHORT = 1e-3, 4.0, 2e-3


def overlapping_pairs(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE, among: np.ndarray | None = None):
    """Pairs ``(earlier, later)`` of collinear segments that share a stretch of line.

    With ``among`` (a boolean mask), only the pairs with at least one of those.

    Returns
    -------
    earlier, later : numpy.ndarray
        Segment indices, ``earlier < later``.
    start, end : numpy.ndarray
        The shared stretch as parameters ``0 <= start < end <= 1`` along ``earlier``.
    """
    twin_of = last_twins(segments)
    searched = twin_of == np.arange(len(segments))
    if tolerance <= COLLINEAR_TOLERANCE:
        chosen = np.intersect1d(_candidates(segments, among), np.flatnonzero(searched))
    else:
        chosen = np.flatnonzero(searched)
    lines = shapely.linestrings(np.stack([segments.p[chosen], segments.q[chosen]], axis=1))
    earlier, later = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tolerance)
    earlier, later = chosen[earlier], chosen[later]
    repeated = np.flatnonzero(~searched)  # wholly covered by their last twin
    earlier, later = np.concatenate([earlier, repeated]), np.concatenate([later, twin_of[repeated]])
    forward = earlier < later if among is None else (earlier < later) & (among[earlier] | among[later])
    return shared_stretches(segments, earlier[forward], later[forward], tolerance)


def last_twins(segments: Segments) -> np.ndarray:
    """For each segment, the index of the last segment with the same end points (either way round)."""
    ends = np.concatenate([segments.p, segments.q], axis=1)
    swap = (segments.q[:, 0] < segments.p[:, 0]) | ((segments.q[:, 0] == segments.p[:, 0])
                                                   & (segments.q[:, 1] < segments.p[:, 1]))
    ends[swap] = ends[swap][:, [2, 3, 0, 1]]
    _, group = np.unique(ends, axis=0, return_inverse=True)
    group = group.reshape(-1)
    last = np.zeros(group.max(initial=-1) + 1, np.int64)
    np.maximum.at(last, group, np.arange(len(segments)))
    return last[group]


def _candidates(segments: Segments, among: np.ndarray | None = None) -> np.ndarray:
    """Indices of the segments that may overlap another collinearly (one of ``among``): a filter before shapely.

    Each segment's line is put in a bucket of direction and offset; a
    segment whose bucket or a neighbouring one holds another segment (of
    ``among``, a boolean mask, when given; those are kept too), or that is
    shorter than ``SHORT`` (its direction says little), is kept.
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
    source = np.ones(len(index), bool) if among is None else among[index]
    occupied, counts = np.unique(flat[source], return_counts=True)
    crowded = np.zeros(len(index), bool)
    for da in (-1, 0, 1):
        for dc in (-1, 0, 1):
            neighbour = flat + da * (1 << 32) + dc
            at = np.clip(np.searchsorted(occupied, neighbour), 0, max(len(occupied) - 1, 0))
            found = np.where(occupied[at] == neighbour, counts[at], 0) if len(occupied) else np.zeros(len(flat), int)
            crowded |= found - (source & (da == 0) & (dc == 0)) > 0
    short = np.hypot(d[:, 0], d[:, 1]) < SHORT
    chosen = np.union1d(np.unique(index[crowded]), np.flatnonzero(short))
    return chosen if among is None else np.union1d(chosen, np.flatnonzero(among))


def reference_pairs(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE):
    """``overlapping_pairs`` by the plain search: every segment against every other near it (shapely)."""
    lines = shapely.linestrings(np.stack([segments.p, segments.q], axis=1))
    earlier, later = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tolerance)
    forward = earlier < later
    return shared_stretches(segments, earlier[forward], later[forward], tolerance)


def shared_stretches(segments: Segments, earlier: np.ndarray, later: np.ndarray, tolerance: float):
    """The pairs of candidates ``earlier < later`` that share a stretch of line, with the stretch along ``earlier``."""
    origin = segments.p[earlier]
    d = segments.q[earlier] - origin  # of these rows only: the search after an edit looks at a few
    length = np.hypot(d[:, 0], d[:, 1])
    t = d / np.maximum(length[:, None], np.finfo(float).tiny)

    def along_and_off(points):
        rel = points[later] - origin
        return (rel * t).sum(axis=1) / np.maximum(length, np.finfo(float).tiny), \
            np.abs(rel[:, 0] * t[:, 1] - rel[:, 1] * t[:, 0])

    (a, off_a), (b, off_b) = along_and_off(segments.p), along_and_off(segments.q)
    start = np.clip(np.minimum(a, b), 0.0, 1.0)
    end = np.clip(np.maximum(a, b), 0.0, 1.0)
    shared = (off_a <= tolerance) & (off_b <= tolerance) & ((end - start) * length > tolerance)
    return earlier[shared], later[shared], start[shared], end[shared]


def drop_covered_parts(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE, pairs=None) -> Segments:
    """``segments`` without the stretches that a later segment covers collinearly.

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
                    tolerance: float = COLLINEAR_TOLERANCE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def drop_covered_parts_reference(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE, pairs=None) -> Segments:
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
