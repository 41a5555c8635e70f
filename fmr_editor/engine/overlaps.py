"""Collinear overlaps between curve segments: the later segment wins.

Real files contain curves that retrace themselves (control points going back
and forth along a line) or lie on top of other curves.  Two segments covering
the same stretch of line prescribe two sets of colours there and make the
boundary-element system singular (identical collocation rows and columns).
As when curves are painted in order into a raster, the segment that comes
later in the document (a later curve, or later along the same curve) keeps
the overlap; earlier ones lose the covered part.
"""

from __future__ import annotations

import numpy as np
import shapely

from .segments import Segments

#: Distance in pixels under which end points count as on another segment's line.
COLLINEAR_TOLERANCE = 1e-6


def overlapping_pairs(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE):
    """Pairs ``(earlier, later)`` of collinear segments that share a stretch of line.

    Returns
    -------
    earlier, later : numpy.ndarray
        Segment indices, ``earlier < later``.
    start, end : numpy.ndarray
        The shared stretch as parameters ``0 <= start < end <= 1`` along ``earlier``.
    """
    lines = shapely.linestrings(np.stack([segments.p, segments.q], axis=1))
    earlier, later = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tolerance)
    forward = earlier < later
    earlier, later = earlier[forward], later[forward]
    d = segments.q - segments.p
    length = np.hypot(d[:, 0], d[:, 1])
    t = d[earlier] / length[earlier, None]

    def along_and_off(points):
        rel = points[later] - segments.p[earlier]
        return (rel * t).sum(axis=1) / length[earlier], np.abs(rel[:, 0] * t[:, 1] - rel[:, 1] * t[:, 0])

    (a, off_a), (b, off_b) = along_and_off(segments.p), along_and_off(segments.q)
    start = np.clip(np.minimum(a, b), 0.0, 1.0)
    end = np.clip(np.maximum(a, b), 0.0, 1.0)
    shared = (off_a <= tolerance) & (off_b <= tolerance) & ((end - start) * length[earlier] > tolerance)
    return earlier[shared], later[shared], start[shared], end[shared]


def drop_covered_parts(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE) -> Segments:
    """``segments`` without the stretches that a later segment covers collinearly."""
    if len(segments) < 2:
        return segments
    earlier, _, start, end = overlapping_pairs(segments, tolerance)
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
