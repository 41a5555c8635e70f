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
still compare more than ``MAX_CANDIDATES`` pairs is refused.
``reference_pairs`` is the plain search (shapely over every segment) the
tests compare with.
"""

from __future__ import annotations

import numpy as np
import shapely

from ...model.limits import LimitError
from .segments import Segments

#: Distance in pixels under which end points count as on another segment's line.
COLLINEAR_TOLERANCE = 1e-6
#: Shortest segment whose direction is trusted (pixels): two collinear segments at least ``SHORT`` long differ
#: by at most 2 tolerance / SHORT (1e-3 radians at the default tolerance) in direction, the angle bucket.
SHORT = 2e-3
#: Smallest bucket of line offset (pixels); larger canvases get larger ones (``_offset_bucket``).
OFFSET_BUCKET = 4.0
#: Most pairs of segments on nearby lines compared (about 40 bytes each).
MAX_CANDIDATES = 10_000_000

#: Range of each field packed into a bucket key (offset and position buckets stay within half of it).
_FIELD = 1 << 20


def overlapping_pairs(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE, among: np.ndarray | None = None):
    """Pairs ``(earlier, later)`` of collinear segments that share a stretch of line.

    With ``among`` (a boolean mask), only the pairs with at least one of those.

    Returns
    -------
    earlier, later : numpy.ndarray
        Segment indices, ``earlier < later``.
    start, end : numpy.ndarray
        The shared stretch as parameters ``0 <= start < end <= 1`` along ``earlier``.

    Raises
    ------
    LimitError
        When more than ``MAX_CANDIDATES`` pairs would be compared.
    """
    twin_of = last_twins(segments)
    searched = twin_of == np.arange(len(segments))
    earlier, later = _nearby_pairs(segments, searched, tolerance, among)
    repeated = np.flatnonzero(~searched)  # wholly covered by their last twin
    earlier, later = np.concatenate([earlier, repeated]), np.concatenate([later, twin_of[repeated]])
    if among is not None:
        wanted = among[earlier] | among[later]
        earlier, later = earlier[wanted], later[wanted]
    return _shared_stretches(segments, earlier, later, tolerance)


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


def _nearby_pairs(segments: Segments, searched: np.ndarray, tolerance: float, among: np.ndarray | None):
    """Candidate pairs ``earlier < later`` among ``searched`` segments: those sharing a bucket of line and of
    position along it (``_bucket_keys``), and any segment near a short one (whose direction says little)."""
    n = len(segments)
    d = segments.q - segments.p
    short = np.hypot(d[:, 0], d[:, 1]) < SHORT
    keys, index = _bucket_keys(segments, np.flatnonzero(searched & ~short), 2 * tolerance / SHORT)
    order = np.argsort(keys, kind="stable")
    keys_sorted = keys[order]
    found, total = [np.zeros(0, np.int64)], 0
    for da in (-1, 0, 1):
        for dc in (-1, 0, 1):
            wanted = keys + (da * _FIELD + dc) * _FIELD
            lo = np.searchsorted(keys_sorted, wanted, "left")
            counts = np.searchsorted(keys_sorted, wanted, "right") - lo
            total += int(counts.sum())
            _check_candidates(total)
            first = index[np.repeat(np.arange(len(keys)), counts)]
            second = index[order[np.repeat(lo - np.cumsum(counts) + counts, counts) + np.arange(len(first))]]
            forward = first < second if among is None else (first < second) & (among[first] | among[second])
            found.append(np.unique(first[forward] * n + second[forward]))
    tiny = np.flatnonzero(searched & short)
    if len(tiny):
        found.append(_pairs_with_tiny(segments, np.flatnonzero(searched), tiny, tolerance))
    pairs = np.unique(np.concatenate(found))
    earlier, later = pairs // max(n, 1), pairs % max(n, 1)
    distinct = earlier < later
    return earlier[distinct], later[distinct]


def _pairs_with_tiny(segments: Segments, searched: np.ndarray, tiny: np.ndarray, tolerance: float) -> np.ndarray:
    """Pairs ``earlier * n + later`` of each ``tiny`` segment with the ``searched`` ones whose box (widened by
    ``tolerance``) holds its start: sorted by x, then checked in y."""
    n = len(segments)
    by_x = tiny[np.argsort(segments.p[tiny, 0])]
    x = segments.p[by_x, 0]
    low = np.minimum(segments.p[searched], segments.q[searched]) - tolerance
    high = np.maximum(segments.p[searched], segments.q[searched]) + tolerance
    lo = np.searchsorted(x, low[:, 0], "left")
    counts = np.searchsorted(x, high[:, 0], "right") - lo
    _check_candidates(int(counts.sum()))
    box = np.repeat(np.arange(len(searched)), counts)
    small = by_x[np.repeat(lo - np.cumsum(counts) + counts, counts) + np.arange(len(box))]
    inside = (segments.p[small, 1] >= low[box, 1]) & (segments.p[small, 1] <= high[box, 1])
    a, b = searched[box[inside]], small[inside]
    return np.minimum(a, b) * n + np.maximum(a, b)


def _check_candidates(count: int) -> None:
    if count > MAX_CANDIDATES:
        raise LimitError(f"the curves lie along each other too often: more than {MAX_CANDIDATES:,} pairs "
                         "of segments on nearly the same stretch of line to compare")


def _bucket_keys(segments: Segments, chosen: np.ndarray, angle_bucket: float) -> tuple[np.ndarray, np.ndarray]:
    """Keys of the buckets ``chosen`` segments lie in, and the segment of each key.

    A bucket is a range of line direction (``angle_bucket``), of line offset
    and of position along the line: two collinear segments that share a
    stretch share a position bucket and lie in neighbouring direction and
    offset buckets.  A direction just below pi also gets the keys of the same
    line just above 0 (normal, offset and positions flipped).
    """
    p, q = segments.p[chosen], segments.q[chosen]
    d = q - p
    theta = np.mod(np.arctan2(d[:, 1], d[:, 0]), np.pi)
    centre = segments.p.mean(axis=0) if len(segments) else np.zeros(2)
    reach = float(np.abs(np.concatenate([segments.p, segments.q]) - centre).max(initial=1.0)) * np.sqrt(2)
    # two collinear segments' directions differ by up to angle_bucket, which moves offsets and positions
    slack = angle_bucket * reach + 2 * COLLINEAR_TOLERANCE
    normal, tangent = np.stack([-np.sin(theta), np.cos(theta)], 1), np.stack([np.cos(theta), np.sin(theta)], 1)
    offset = (normal * (p - centre)).sum(1)
    along = np.sort(np.stack([(tangent * (p - centre)).sum(1), (tangent * (q - centre)).sum(1)], 1), axis=1)
    wraps = theta > np.pi - 2 * angle_bucket
    theta = np.concatenate([theta, theta[wraps] - np.pi])
    offset = np.concatenate([offset, -offset[wraps]])
    along = np.concatenate([along, -along[wraps][:, ::-1]])
    index = np.concatenate([chosen, chosen[wraps]])
    offset_bucket = max(OFFSET_BUCKET, 2 * slack, 4 * reach / _FIELD)
    lengths = along[:, 1] - along[:, 0]
    position_bucket = max(4 * float(np.median(lengths)) if len(lengths) else 1.0, 2 * slack, 4 * reach / _FIELD)
    first = np.floor((along[:, 0] - slack) / position_bucket).astype(np.int64)
    spans = np.floor((along[:, 1] + slack) / position_bucket).astype(np.int64) - first + 1
    entry = np.repeat(np.arange(len(index)), spans)
    position = first[entry] + np.arange(len(entry)) - np.repeat(np.cumsum(spans) - spans, spans)
    line = (np.floor(theta / angle_bucket).astype(np.int64) * _FIELD
            + np.floor(offset / offset_bucket).astype(np.int64))
    return line[entry] * _FIELD + position, index[entry]


def reference_pairs(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE):
    """``overlapping_pairs`` by the plain search: every segment against every other near it (shapely)."""
    lines = shapely.linestrings(np.stack([segments.p, segments.q], axis=1))
    earlier, later = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tolerance)
    forward = earlier < later
    return _shared_stretches(segments, earlier[forward], later[forward], tolerance)


def _shared_stretches(segments: Segments, earlier: np.ndarray, later: np.ndarray, tolerance: float):
    """The pairs of candidates ``earlier < later`` that share a stretch of line, with the stretch along ``earlier``."""
    d = segments.q - segments.p
    length = np.hypot(d[:, 0], d[:, 1])
    t = d[earlier] / np.maximum(length[earlier, None], np.finfo(float).tiny)

    def along_and_off(points):
        rel = points[later] - segments.p[earlier]
        return (rel * t).sum(axis=1) / np.maximum(length[earlier], np.finfo(float).tiny), \
            np.abs(rel[:, 0] * t[:, 1] - rel[:, 1] * t[:, 0])

    (a, off_a), (b, off_b) = along_and_off(segments.p), along_and_off(segments.q)
    start = np.clip(np.minimum(a, b), 0.0, 1.0)
    end = np.clip(np.maximum(a, b), 0.0, 1.0)
    shared = (off_a <= tolerance) & (off_b <= tolerance) & ((end - start) * length[earlier] > tolerance)
    return earlier[shared], later[shared], start[shared], end[shared]
def drop_covered_parts(segments: Segments, tolerance: float = COLLINEAR_TOLERANCE, pairs=None) -> Segments:
    """``segments`` without the stretches that a later segment covers collinearly.

    ``pairs``: ``overlapping_pairs(segments, tolerance)`` when known already.
    """
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
