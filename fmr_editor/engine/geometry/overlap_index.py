"""The overlapping pairs of a document's curve segments, kept up to date edit by edit.

``overlaps.overlapping_pairs`` searches a whole set.  The pairs it finds are
fixed by the segments alone: each repeated segment (one with a later twin,
``overlaps.last_twins``) paired with its last twin, and every pair of other
("searched") segments that GEOS's prepared ``dwithin`` (as its STRtree query
runs it) and ``shared_stretches`` accept.  Its bucket filter (``_candidates``)
only narrows the search: two segments where one covers the other lie in
neighbouring buckets.  So when an edit replaces a few curves,
the pairs among untouched segments stay, except those of segments whose twins
changed (a new last twin, or the last one gone), and only the new segments and
those are searched for: ``OverlapIndex.updated``.

The search looks in an STRtree of the segments as they were when it was built
and in a small tree of the rows added since (rebuilt once those grow many); it
finds twins too, as segments at distance 0 with the same end points.
``tests/test_curve_cache.py`` holds the result to ``overlapping_pairs``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from .overlaps import COINCIDENT_DISTANCE, last_twins, segment_lines, shared_stretches, within_pairs
from .segments import Segments
from .splice import Blocks

#: Rows added since the tree was built, beyond which it is built anew (and at least this share of all rows).
REBUILD_ROWS, REBUILD_SHARE = 4096, 0.125


@dataclass(frozen=True)
class RowIds:
    """Stable ids of a document's segment rows: curve ``i``'s rows have the ids ``first[i]``, ``first[i] + 1``, ...

    Different curves' ids never overlap; a curve kept from one document to the next keeps its ids.
    """

    first: np.ndarray
    counts: np.ndarray

    @property
    def ends(self) -> np.ndarray:
        """Each curve's rows end here (the next curve's start)."""
        return np.cumsum(self.counts)

    def rows(self, ids: np.ndarray) -> np.ndarray:
        """The rows holding ``ids`` now, -1 for ids of segments gone."""
        order = np.argsort(self.first, kind="stable")
        curve = order[np.maximum(np.searchsorted(self.first[order], ids, side="right") - 1, 0)]
        local = ids - self.first[curve]
        inside = (local >= 0) & (local < self.counts[curve])
        return np.where(inside, self.ends[curve] - self.counts[curve] + local, -1)

    def ids(self, rows: np.ndarray) -> np.ndarray:
        """The ids of ``rows``."""
        curve = np.searchsorted(self.ends, rows, side="right")
        return self.first[curve] + rows - (self.ends[curve] - self.counts[curve])

    def rows_of(self, curves: np.ndarray) -> np.ndarray:
        """The rows of ``curves`` (sorted indices), in order."""
        counts = self.counts[curves]
        starts = (self.ends - self.counts)[curves]
        return np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(int(counts.sum()))


class OverlapIndex:
    """What finding a document's overlapping pairs after an edit needs: a spatial index and the repeated segments.

    Parameters
    ----------
    segments : Segments
        The document's clipped curve segments.
    ids : RowIds
        Their ids.
    tolerance : float
        As for ``overlaps.overlapping_pairs``.

    Attributes
    ----------
    repeated : numpy.ndarray
        The rows that have a later twin (same end points), sorted.
    searched : int
        Segments whose neighbours the update that made this index looked up (0 for a new index).
    """

    def __init__(self, segments: Segments, ids: RowIds, tolerance: float = COINCIDENT_DISTANCE) -> None:
        self.tolerance = tolerance
        self.repeated = np.flatnonzero(last_twins(segments) != np.arange(len(segments)))
        self.searched = 0
        self._plant(segments, ids)

    def _plant(self, segments: Segments, ids: RowIds) -> None:
        """Put all of ``segments`` in the tree."""
        self._tree = shapely.STRtree(segment_lines(segments, np.arange(len(segments))))
        self._tree_ids = ids.ids(np.arange(len(segments)))
        self._tree_curves = np.unique(np.append(ids.first, -1))  # the curves (by first id) in the tree, all rows

    def updated(self, old: Segments, new: Segments, blocks: Blocks, ids: RowIds,
                pairs: tuple) -> tuple[OverlapIndex, tuple, np.ndarray]:
        """The index, the pairs and the rows whose pairs as ``earlier`` changed after an edit.

        Parameters
        ----------
        old, new : Segments
            The segments before and after; rows kept are bit for bit the same and in the same order.
        blocks : Blocks
            Which rows of ``new`` are rows of ``old``.
        ids : RowIds
            The ids of ``new``'s rows: a kept curve's as before, a new curve's unlike any the index has seen.
        pairs : tuple
            ``overlapping_pairs(old)``.

        Returns
        -------
        index : OverlapIndex
        pairs : tuple
            ``overlapping_pairs(new)`` (in another order).
        changed : numpy.ndarray
            Sorted rows of ``new`` that are new or whose pairs as ``earlier`` differ from before.
        """
        tolerance = self.tolerance
        fresh, gone = blocks.fresh_rows(), blocks.gone(len(old))
        at = np.minimum(np.searchsorted(self._tree_curves, ids.first), len(self._tree_curves) - 1)
        extra = ids.rows_of(np.flatnonzero(self._tree_curves[at] != ids.first))  # curves not in the tree
        near = _Near(self, ids, new, extra)
        # one search for the rows that came (their twins and pairs) and went (their twins)
        asked, found = near(np.concatenate([segment_lines(new, fresh), segment_lines(old, gone)]))
        twins, affected, repeated = self._twins(old, new, blocks, fresh, gone, asked, found)
        from_fresh = asked < len(fresh)
        asked, found = fresh[asked[from_fresh]], found[from_fresh]
        is_repeated = np.zeros(len(new), bool)
        is_repeated[repeated] = True
        searched = affected[~is_repeated[affected]]  # kept rows that became their twins' last
        if len(searched):
            more_asked, more_found = near(segment_lines(new, searched))
            asked, found = np.concatenate([asked, searched[more_asked]]), np.concatenate([found, more_found])
        keep = (found != asked) & ~is_repeated[asked] & ~is_repeated[found]
        earlier, later = _distinct_pairs(np.minimum(asked, found)[keep], np.maximum(asked, found)[keep])
        among = np.union1d(fresh, affected)
        among = among[is_repeated[among]]
        found = [shared_stretches(new, *within_pairs(new, earlier, later, tolerance), tolerance),
                 shared_stretches(new, among, twins[1][np.searchsorted(twins[0], among)], tolerance)]

        old_earlier, old_later = blocks.to_new(pairs[0]), blocks.to_new(pairs[1])
        is_affected = np.zeros(len(new), bool)
        is_affected[affected] = True
        stay = (old_earlier >= 0) & (old_later >= 0)
        stay[stay] = ~is_affected[old_earlier[stay]] & ~is_affected[old_later[stay]]
        pairs = tuple(np.concatenate([part[stay], *(pair[i] for pair in found)])
                      for i, part in enumerate((old_earlier, old_later, pairs[2], pairs[3])))
        left = old_earlier[~stay]
        changed = np.unique(np.concatenate([fresh, left[left >= 0], *(pair[0] for pair in found)]))

        index = OverlapIndex.__new__(OverlapIndex)  # this one may be kept too (a copied cache): a new one
        index.tolerance, index.repeated, index.searched = tolerance, repeated, len(fresh) + len(gone) + len(searched)
        if len(extra) > max(REBUILD_ROWS, REBUILD_SHARE * len(new)):
            index._plant(new, ids)
        else:
            index._tree, index._tree_ids, index._tree_curves = self._tree, self._tree_ids, self._tree_curves
        return index, pairs, changed

    def _twins(self, old: Segments, new: Segments, blocks: Blocks, fresh: np.ndarray, gone: np.ndarray,
               asked: np.ndarray, found: np.ndarray) -> tuple[tuple, np.ndarray, np.ndarray]:
        """The twins of the rows that came (``fresh``) and went (``gone``) after an edit.

        ``asked``, ``found``: pairs of those rows (the new ones, then the
        ones gone) and rows now near them: their twins among those.

        Returns
        -------
        twins : tuple of numpy.ndarray
            The rows of ``new`` in those groups of twins (sorted) and the last twin of each.
        affected : numpy.ndarray
            Rows kept from ``old`` whose last twin changed (they pair differently now).
        repeated : numpy.ndarray
            The rows of ``new`` with a later twin.
        """
        ends = np.concatenate([_ends(new, fresh), _ends(old, gone)])
        equal = np.all(ends[asked] == _ends(new, found), axis=1)
        group = np.unique(ends, axis=0, return_inverse=True)[1].reshape(-1)  # equal end points, one group
        groups = group.max(initial=-1) + 1
        member_group, member = _distinct_pairs(group[asked[equal]], found[equal])  # (group, row now) once each
        last_now = np.full(groups, -1, np.int64)
        np.maximum.at(last_now, member_group, member)
        was = np.concatenate([blocks.to_old(member), gone])
        was_group = np.concatenate([member_group, group[len(fresh):]])
        last_before = np.full(groups, -1, np.int64)
        np.maximum.at(last_before, was_group[was >= 0], was[was >= 0])
        new_last = np.where(last_before >= 0, blocks.to_new(np.maximum(last_before, 0)), -1) != last_now
        affected = np.unique(member[new_last[member_group] & (was[:len(member)] >= 0)])
        touched = np.zeros(len(new), bool)
        touched[member] = True
        kept = blocks.to_new(self.repeated)
        kept = kept[kept >= 0]
        repeated = np.union1d(kept[~touched[kept]], member[member != last_now[member_group]])
        order = np.argsort(member, kind="stable")
        return (member[order], last_now[member_group][order]), affected, repeated


class _Near:
    """Rows of a document near given lines: in an index's tree (as they were when it was built) or among the
    ``extra`` rows (those of curves not in the tree), of ``segments``."""

    def __init__(self, index: OverlapIndex, ids: RowIds, segments: Segments, extra: np.ndarray) -> None:
        self.index, self.ids, self.extra = index, ids, extra
        self.extra_tree = shapely.STRtree(segment_lines(segments, extra))

    def __call__(self, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs ``(line, row)`` of ``lines`` and rows within twice the tolerance of them (a superset of the pairs
        ``dwithin`` accepts either way round)."""
        distance = 2 * self.index.tolerance
        asked, item = self.index._tree.query(lines, predicate="dwithin", distance=distance)
        rows = self.ids.rows(self.index._tree_ids[item])
        extra_asked, extra_item = self.extra_tree.query(lines, predicate="dwithin", distance=distance)
        asked = np.concatenate([asked[rows >= 0], extra_asked])
        return asked, np.concatenate([rows[rows >= 0], self.extra[extra_item]])


def _ends(segments: Segments, rows: np.ndarray) -> np.ndarray:
    """End points ``(n, 4)`` of ``rows`` in the order ``overlaps.last_twins`` compares them."""
    p, q = segments.p[rows], segments.q[rows]
    swap = (q[:, 0] < p[:, 0]) | ((q[:, 0] == p[:, 0]) & (q[:, 1] < p[:, 1]))
    return np.where(swap[:, None], np.concatenate([q, p], axis=1), np.concatenate([p, q], axis=1))


def _distinct_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct pairs ``(a, b)`` of non-negative integers, sorted."""
    a, b = np.asarray(a, np.int64), np.asarray(b, np.int64)
    if len(a) == 0:
        return a, b
    scale = int(b.max()) + 1
    pairs = np.unique(a * scale + b)
    return pairs // scale, pairs % scale
