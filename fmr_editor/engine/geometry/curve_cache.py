"""A document's curves as clipped segments, kept from one edit to the next.

``discretise.curve_segments`` flattens every curve, clips them to the canvas
and lets later segments keep overlaps (``overlaps``); the last step
searches the whole set.  An edit changes a few curves, so ``CurveSegments``
keeps each curve's flattened and clipped segments, the overlapping pairs and
an index to find the pairs of new segments (``overlap_index``), and the
result, row by row: after an edit it works out the pieces of the rows whose
pairs changed and takes the others' over (``splice``).  Its result equals
``curve_segments``'s bit for bit (tested).

Two things make every row's bits depend on the whole document, as in
``curve_segments``: when some curve leaves the canvas every segment goes
through the clip's arithmetic (``clip_to_canvas`` splits them all), and when
some pair overlaps every segment goes through the split of
``drop_covered_parts``.  A change of either starts afresh.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import repeat
from operator import is_

import numpy as np

from ...model import DiffusionCurve, Document
from ...model.limits import LimitError
from ..memory import check_build_memory
from .discretise import clip_to_canvas, from_curve
from .flatten import flatten_curves, flattened_count
from .overlap_index import OverlapIndex, RowIds
from .overlaps import overlapping_pairs, uncovered_parts
from .segments import Segments, concatenate, empty_segments
from .splice import Blocks, row_starts, splice

#: Most segments the curves of a document may be flattened into (roses: 70,000).
MAX_SEGMENTS = 2_000_000
#: Share of rows new in an edit beyond which everything is worked out afresh.
FRESH_SHARE = 0.25


class _Curve:
    """One curve object's segments: flattened (their origin the curve's id), and clipped as each canvas asks."""

    __slots__ = ("curve", "flat", "first_id", "_clipped")

    def __init__(self, curve: DiffusionCurve, flat: Segments, first_id: int) -> None:
        self.curve, self.flat, self.first_id = curve, from_curve(flat, curve.id), first_id
        self._clipped: dict[tuple[float, float], Segments] = {}

    def clipped(self, width: float, height: float) -> Segments:
        """``clip_to_canvas`` of the curve's segments alone."""
        clipped = self._clipped.get((width, height))
        if clipped is None:
            clipped = self._clipped[(width, height)] = clip_to_canvas(self.flat, width, height)
        return clipped

    def inside(self, width: float, height: float) -> bool:
        """Whether the canvas holds all the curve's segments (``clip_to_canvas`` leaves them alone)."""
        return self.clipped(width, height) is self.flat

    def rows(self, width: float, height: float, clip_all: bool) -> Segments:
        """The curve's rows of ``clip_to_canvas`` of a document's segments (which split them all when ``clip_all``,
        some segment lying outside)."""
        if not clip_all or not self.inside(width, height):
            return self.clipped(width, height)
        key = (width, height, True)
        split = self._clipped.get(key)
        if split is None:
            n = len(self.flat)
            split = self._clipped[key] = self.flat.split(np.arange(n), np.zeros(n), np.ones(n))
        return split


class _Rows:
    """A document's clipped curve segments held as each curve's rows, with all end points at hand (the overlap
    search reads those; other fields are read only for a few rows, and copying them all would cost an edit more
    than the rest of it).

    Parameters
    ----------
    parts : list of Segments
        Each curve's rows.
    ends : numpy.ndarray
        Where each curve's rows end.
    p, q : numpy.ndarray
        All rows' end points.
    """

    def __init__(self, parts: list[Segments], ends: np.ndarray, p: np.ndarray, q: np.ndarray) -> None:
        self.parts, self.ends, self.p, self.q = parts, ends, p, q

    def __len__(self) -> int:
        return len(self.p)

    def take(self, rows: np.ndarray) -> Segments:
        """The segments at ``rows`` (sorted)."""
        curve = np.searchsorted(self.ends, rows, side="right")
        first = np.flatnonzero(np.diff(curve, prepend=-1))
        bounds = np.append(first, len(rows))
        return concatenate([empty_segments()] + [
            self.parts[c].take(rows[a:b] - (self.ends[c] - len(self.parts[c])))
            for c, a, b in zip(curve[first].tolist(), bounds[:-1].tolist(), bounds[1:].tolist())])

    def split(self, owner: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> Segments:
        """``Segments.split`` (``owner`` sorted)."""
        pieces = self.take(owner)
        return pieces.split(np.arange(len(pieces)), t0, t1)

    def whole(self) -> Segments:
        """All rows as one ``Segments``."""
        return concatenate([empty_segments(), *self.parts])


@dataclass(frozen=True)
class _Result:
    """What one call of ``CurveSegments.segments`` worked out (never changed afterwards)."""

    curves: tuple[DiffusionCurve, ...]
    entries: list[_Curve]
    position: dict[int, int]  # id(curve) -> its index
    canvas: tuple[float, float]
    outside: int  # curves not wholly inside the canvas
    ids: RowIds  # of the clipped rows
    clipped: Segments | _Rows
    parts: list[Segments]  # each curve's clipped rows
    pairs: tuple
    index: OverlapIndex | None
    output: Segments
    output_starts: np.ndarray | None  # where each clipped row's pieces start in output; None: one piece each


class CurveSegments:
    """``curve_segments`` of one document after another, reusing what an edit left alone.

    Parameters
    ----------
    tolerance, max_length : float
        As for ``discretise.curve_segments``.

    Attributes
    ----------
    last_search : int
        Segments whose neighbours the last call looked up (all of them when it started afresh).
    """

    def __init__(self, tolerance: float, max_length: float) -> None:
        self.tolerance, self.max_length = tolerance, max_length
        self._entries: dict[int, _Curve] = {}  # id(curve) -> its segments (the entry holds the curve)
        self._next_id = 0
        self._last: _Result | None = None
        self.last_search = 0

    def copy(self) -> CurveSegments:
        """An independent cache holding what this one holds (the segments themselves shared: they never change)."""
        twin = CurveSegments(self.tolerance, self.max_length)
        twin._entries, twin._next_id, twin._last = dict(self._entries), self._next_id, self._last
        return twin

    def forget(self, keep: tuple[DiffusionCurve, ...]) -> None:
        """Drop the kept segments of curves in neither ``keep`` nor the last document."""
        stale = self._entries.keys() - (self._last.position.keys() if self._last is not None else ())
        for key in stale:  # few (the curves an edit replaced): each looked for in keep, not keep hashed
            if not any(map(is_, keep, repeat(self._entries[key].curve))):
                del self._entries[key]

    def segments(self, document: Document) -> Segments:
        """The document's curve segments, as ``discretise.curve_segments(document, tolerance, max_length)``."""
        curves, canvas, last = document.curves, (float(document.width), float(document.height)), self._last
        if last is not None and last.canvas == canvas:
            was = np.fromiter(map(last.position.get, map(id, curves), repeat(-1)), np.int64, len(curves))
        else:
            was = np.full(len(curves), -1, np.int64)
        fresh = np.flatnonzero(was < 0)
        self._check_size(curves, canvas, was, fresh)
        entries = self._entries_of(curves, was, fresh)
        outside = self._outside_after_edit(entries, canvas, was, fresh)
        if outside is None:
            self._last = self._afresh(curves, entries, canvas)
        else:
            self._last = self._updated(curves, entries, canvas, outside, was, fresh)
        return self._last.output

    def _outside_after_edit(self, entries: list[_Curve], canvas: tuple[float, float], was: np.ndarray,
                            fresh: np.ndarray) -> int | None:
        """How many curves lie partly outside the canvas, when the last result may be brought to ``entries``; else
        None: it is another canvas, curves were reordered, many are new, or the clip's arithmetic changes."""
        last, kept = self._last, was[was >= 0]
        if last is None or last.canvas != canvas or last.index is None or not len(kept) or np.any(np.diff(kept) <= 0):
            return None
        if sum(len(entries[i].flat) for i in fresh) > FRESH_SHARE * len(last.clipped):
            return None
        gone = np.ones(len(last.curves), bool)
        gone[kept] = False
        gone = np.flatnonzero(gone)
        outside = last.outside - sum(not last.entries[j].inside(*canvas) for j in gone) + sum(
            not entries[i].inside(*canvas) for i in fresh)
        return outside if (outside > 0) == (last.outside > 0) else None

    def _check_size(self, curves: tuple[DiffusionCurve, ...], canvas: tuple[float, float], was: np.ndarray,
                    fresh: np.ndarray) -> None:
        """Refuse ``curves`` that would make more segments than the limit or the memory allow, before the new
        ones are flattened."""
        count = int(self._last.ids.counts[was[was >= 0]].sum()) if self._last is not None else 0
        known = [self._entries.get(id(curves[i])) for i in fresh]
        count += sum(len(entry.clipped(*canvas)) for entry in known if entry is not None)
        count += flattened_count([curves[i] for i, entry in zip(fresh, known) if entry is None], self.tolerance,
                                 self.max_length)
        if count > MAX_SEGMENTS:
            raise LimitError(f"the curves make about {count:,} segments, more than the {MAX_SEGMENTS:,} allowed")
        check_build_memory(count)

    def _entries_of(self, curves: tuple[DiffusionCurve, ...], was: np.ndarray, fresh: np.ndarray) -> list[_Curve]:
        """Each curve's entry: the last document's, a kept one, or made now (all new curves flattened at once)."""
        if len(fresh) < len(curves):  # (a new curve's place holds the last curve's entry until it gets its own)
            entries = list(map(self._last.entries.__getitem__, was.tolist()))
        else:
            entries = [None] * len(curves)
        new = {id(curves[i]): curves[i] for i in fresh if id(curves[i]) not in self._entries}
        for curve, flat in zip(new.values(), flatten_curves(list(new.values()), self.tolerance, self.max_length)):
            self._entries[id(curve)] = _Curve(curve, flat, self._next_id)
            self._next_id += max(len(flat), 1)  # a curve of no segments still gets an id of its own
        for i in fresh:
            entries[i] = self._entries[id(curves[i])]
        return entries

    def _afresh(self, curves: tuple[DiffusionCurve, ...], entries: list[_Curve],
                canvas: tuple[float, float]) -> _Result:
        """Everything worked out from the curves' segments: the plain ``curve_segments``, with what edits need."""
        outside = sum(not entry.inside(*canvas) for entry in entries)
        parts = [entry.rows(*canvas, outside > 0) for entry in entries]
        clipped = concatenate([empty_segments(), *parts])
        ids = RowIds(np.array([entry.first_id for entry in entries], np.int64),
                     np.array([len(part) for part in parts], np.int64))
        pairs = overlapping_pairs(clipped)
        distinct = len(set(map(id, curves))) == len(curves)
        index = OverlapIndex(clipped, ids) if distinct else None  # the same curve twice: ids would be ambiguous
        self.last_search = len(clipped)
        output, output_starts = _dropped(clipped, pairs)
        return _Result(curves, entries, dict(zip(map(id, curves), range(len(curves)))), canvas, outside, ids,
                       _Rows(parts, ids.ends, clipped.p, clipped.q), parts, pairs, index, output, output_starts)

    def _updated(self, curves: tuple[DiffusionCurve, ...], entries: list[_Curve], canvas: tuple[float, float],
                 outside: int, was: np.ndarray, fresh: np.ndarray) -> _Result:
        """The last result brought to ``curves``, whose curves kept from it (``was`` >= 0) keep their order."""
        last = self._last
        parts = list(map(last.parts.__getitem__, was.tolist()))
        for i in fresh:
            parts[i] = entries[i].rows(*canvas, outside > 0)
        counts = last.ids.counts[was]
        counts[fresh] = [len(parts[i]) for i in fresh]
        first = last.ids.first[was]
        first[fresh] = [entries[i].first_id for i in fresh]
        ids = RowIds(first, counts)
        fresh_rows = concatenate([empty_segments()] + [parts[i] for i in fresh])
        # a kept curve's rows are the same rows of the last result, a new curve's are new
        blocks = Blocks.of(counts, np.where(was >= 0, (last.ids.ends - last.ids.counts)[was], -1))
        (p, q), _ = splice(last.clipped, None, blocks, fresh_rows, None, ("p", "q"))
        clipped = _Rows(parts, ids.ends, p, q)
        index, pairs, changed = last.index.updated(last.clipped, clipped, blocks, ids, last.pairs)
        self.last_search = index.searched
        if _splits(clipped, pairs) != _splits(last.clipped, last.pairs):
            output, output_starts = _dropped(clipped.whole(), pairs)
        elif not _splits(clipped, pairs):  # each row its own piece, as it is
            output, output_starts = splice(last.output, None, blocks, fresh_rows, None)
        else:
            owner, t0, t1 = uncovered_parts(clipped, pairs[0], pairs[2], pairs[3], changed)
            output, output_starts = splice(last.output, last.output_starts, blocks.refreshed(changed),
                                           clipped.split(owner, t0, t1), row_starts(owner, changed))
        return _Result(curves, entries, dict(zip(map(id, curves), range(len(curves)))), canvas, outside, ids,
                       clipped, parts, pairs, index, output, output_starts)


def _splits(segments: Segments | _Rows, pairs: tuple) -> bool:
    """Whether ``drop_covered_parts`` splits ``segments`` (every row then goes through ``Segments.split``)."""
    return len(segments) >= 2 and len(pairs[0]) > 0


def _dropped(segments: Segments, pairs: tuple) -> tuple[Segments, np.ndarray | None]:
    """``drop_covered_parts(segments, pairs=pairs)`` and where each row's pieces start in it (None: each row is its
    own piece)."""
    if not _splits(segments, pairs):
        return segments, None
    owner, t0, t1 = uncovered_parts(segments, pairs[0], pairs[2], pairs[3], np.arange(len(segments)))
    return segments.split(owner, t0, t1), row_starts(owner, len(segments))
