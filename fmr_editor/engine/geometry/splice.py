"""Row-wise results kept between edits: the pieces of unchanged rows taken over, only changed rows worked out.

Cutting segments at cell edges (``discretise.cut_at_cells``), dropping their
covered parts (``overlaps.drop_covered_parts``) and clipping curves make each
input row's pieces from that row alone (and from data the caller tracks), and
put them out row after row in input order.  So after an edit that changed a
few rows, the output is the old output with the pieces of those rows replaced:
``Blocks`` says which rows come from where, ``splice`` assembles the output
from slices, ``reused_rows`` finds which rows of a new input equal (bit for
bit) rows of an old one, and ``RowCache`` keeps the last few inputs and
outputs of such a row-wise function for callers that know nothing of the edit.

Everything here works on runs of rows, not on arrays with an entry per row:
the engine gives arrays of 16 MB or more pages of their own
(``memory.return_freed_arrays``), so each such temporary costs its page
faults, and on roses those cost an edit more than the copying itself.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .segments import _FIELDS, Segments, concatenate, empty_segments


@dataclass(frozen=True)
class Blocks:
    """Where each row of a new input comes from: runs of rows of an old input, or of rows worked out anew.

    Block ``k`` covers the rows ``at[k]:at[k] + length[k]``: the old rows
    ``source[k]:source[k] + length[k]``, or, when ``source[k]`` is -1, the
    next ``length[k]`` new rows.  The blocks tile the rows in order.
    """

    at: np.ndarray
    length: np.ndarray
    source: np.ndarray

    @classmethod
    def of(cls, length: np.ndarray, source: np.ndarray) -> Blocks:
        """Consecutive blocks of these lengths and sources, the empty ones left out and runs joined."""
        length, source = np.asarray(length, np.int64), np.asarray(source, np.int64)
        keep = length > 0
        length, source = length[keep], source[keep]
        at = np.cumsum(length) - length
        fresh = source < 0
        joins = np.zeros(len(length), bool)
        joins[1:] = (fresh[1:] & fresh[:-1]) | (~fresh[1:] & ~fresh[:-1] & (source[1:] == source[:-1] + length[:-1]))
        first = np.flatnonzero(~joins)
        return cls(at[first], np.add.reduceat(length, first) if len(first) else length[:0], source[first])

    @property
    def rows(self) -> int:
        return int(self.length.sum())

    @property
    def taken(self) -> int:
        """Rows taken over from the old input."""
        return int(self.length[self.source >= 0].sum())

    def fresh_rows(self) -> np.ndarray:
        """The rows worked out anew, sorted."""
        fresh = self.source < 0
        return _ranges(self.at[fresh], self.length[fresh])

    def gone(self, old_rows: int) -> np.ndarray:
        """The rows of an old input of ``old_rows`` rows that no block takes, sorted."""
        kept = self.source >= 0
        start, length = self.source[kept], self.length[kept]
        order = np.argsort(start, kind="stable")
        start, end = start[order], (start + length)[order]
        gaps_from, gaps_to = np.concatenate([[0], end]), np.concatenate([start, [old_rows]])
        return _ranges(gaps_from, np.maximum(gaps_to - gaps_from, 0))

    def to_old(self, rows: np.ndarray) -> np.ndarray:
        """The old row each of ``rows`` takes, -1 for rows worked out anew."""
        block = np.searchsorted(self.at, rows, side="right") - 1
        source = self.source[block]
        return np.where(source >= 0, source + rows - self.at[block], -1)

    def to_new(self, old_rows: np.ndarray) -> np.ndarray:
        """The row that takes each of ``old_rows``, -1 for rows no block takes."""
        kept = np.flatnonzero(self.source >= 0)
        kept = kept[np.argsort(self.source[kept], kind="stable")]
        if not len(kept):
            return np.full(len(old_rows), -1, np.int64)
        block = kept[np.maximum(np.searchsorted(self.source[kept], old_rows, side="right") - 1, 0)]
        offset = old_rows - self.source[block]
        return np.where((offset >= 0) & (offset < self.length[block]), self.at[block] + offset, -1)

    def refreshed(self, rows: np.ndarray) -> Blocks:
        """These blocks with ``rows`` (sorted, distinct) worked out anew too."""
        if not len(rows):
            return self
        bounds = np.union1d(np.concatenate([self.at, rows, rows + 1]), [self.rows])
        bounds = bounds[bounds <= self.rows]
        start, length = bounds[:-1], np.diff(bounds)
        block = np.searchsorted(self.at, start, side="right") - 1
        source = np.where(self.source[block] >= 0, self.source[block] + start - self.at[block], -1)
        source[np.isin(start, rows)] = -1
        return Blocks.of(length, source)


def _ranges(start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The integers ``start[k]:start[k] + length[k]`` for every ``k``, in order."""
    return np.repeat(start - np.cumsum(length) + length, length) + np.arange(int(length.sum()))


def row_starts(owner: np.ndarray, rows: np.ndarray | int) -> np.ndarray:
    """Where the pieces of ``rows`` (sorted; an int: ``range(rows)``) start among pieces of rows ``owner``
    (sorted), and where the last ends."""
    rows = np.arange(rows) if np.isscalar(rows) else rows
    return np.append(np.searchsorted(owner, rows), len(owner)).astype(np.int64)


def splice(old: Segments, old_starts: np.ndarray | None, blocks: Blocks, fresh: Segments,
           fresh_starts: np.ndarray | None, fields: Sequence[str] = _FIELDS):
    """The pieces of rows, in row order, taken over from an earlier output or worked out anew (``blocks``).

    Parameters
    ----------
    old : Segments
        The earlier output; old row ``k`` made the pieces ``old_starts[k]:old_starts[k + 1]``.
    old_starts : numpy.ndarray or None
        None: one piece a row (the rows themselves).
    blocks : Blocks
    fresh : Segments
        The pieces of the rows worked out anew, in row order; the ``j``-th such row made
        ``fresh_starts[j]:fresh_starts[j + 1]``.
    fresh_starts : numpy.ndarray or None
        None: one piece a row.
    fields : sequence of str
        All of ``Segments``'s (the default), or only these, put out as a tuple of arrays.

    Returns
    -------
    pieces : Segments or tuple of numpy.ndarray
    starts : numpy.ndarray or None
        Where each row's pieces start in ``pieces``, and where the last ends; None when both inputs had one piece
        a row.
    """
    whole = fields is _FIELDS
    one_each = old_starts is None and fresh_starts is None
    old_starts = np.arange(len(old) + 1) if old_starts is None and not one_each else old_starts
    fresh_starts = np.arange(len(fresh) + 1) if fresh_starts is None and not one_each else fresh_starts
    old_rows = len(old) if old_starts is None else len(old_starts) - 1
    if len(blocks.at) == 0 or (len(blocks.at) == 1 and blocks.source[0] < 0):  # all anew
        only, starts = fresh, fresh_starts
    elif len(blocks.at) == 1 and blocks.source[0] == 0 and blocks.rows == old_rows:  # all as before
        only, starts = old, old_starts
    else:
        only = None
    if only is not None:
        return (only if whole else tuple(getattr(only, name) for name in fields)), starts
    starts = None if one_each else np.empty(blocks.rows + 1, np.int64)
    slices, done, taken = [], 0, 0  # pieces put out, new rows taken
    for at, length, source in zip(blocks.at.tolist(), blocks.length.tolist(), blocks.source.tolist()):
        pieces, first, given = (old, source, old_starts) if source >= 0 else (fresh, taken, fresh_starts)
        a, b = (first, first + length) if one_each else (int(given[first]), int(given[first + length]))
        if not one_each:
            np.add(given[first + 1:first + length + 1], done - a, out=starts[at + 1:at + length + 1])
        slices.append((pieces, a, b))
        taken += length if source < 0 else 0
        done += b - a
    if starts is not None:
        starts[0] = 0
    arrays = tuple(np.concatenate([getattr(pieces, name)[a:b] for pieces, a, b in slices]) for name in fields)
    return (Segments(*arrays) if whole else arrays), starts


def differing_rows(a: Segments, b: Segments, rows_a: slice = slice(None), rows_b: slice = slice(None)) -> np.ndarray:
    """The rows (sorted, counted from the slices' starts) where ``rows_a`` of ``a`` and ``rows_b`` of ``b`` (as
    many) differ in some bit of some field."""
    found = []
    for name in _FIELDS:
        x, y = getattr(a, name)[rows_a], getattr(b, name)[rows_b]
        if x.dtype == np.float64:  # bits, not values: -0.0 and 0.0 differ, NaN equals NaN
            x, y = x.view(np.int64), y.view(np.int64)
        per_row = x[0].size if len(x) else 1
        found.append(np.flatnonzero(x.reshape(-1) != y.reshape(-1)) // per_row)  # few: cheaper than .all(axis=1)
    return np.unique(np.concatenate(found))


def reused_rows(old: Segments, new: Segments) -> Blocks:
    """Where the rows of ``new`` are rows of ``old`` with the same bits in every field (the others: anew).

    Rows are matched in place when both have one length (any rows may
    differ), else by the longest common start and end.
    """
    if new is old or len(new) == len(old):
        same = Blocks.of([len(new)], [0])
        return same if new is old else same.refreshed(differing_rows(old, new))
    m = min(len(old), len(new))
    head = differing_rows(old, new, slice(0, m), slice(0, m))
    start = int(head[0]) if len(head) else m
    tail = differing_rows(old, new, slice(len(old) - m + start, len(old)), slice(len(new) - m + start, len(new)))
    end = m - start - 1 - int(tail[-1]) if len(tail) else m - start
    return Blocks.of([start, len(new) - start - end, end], [0, -1, len(old) - end])


class RowCache:
    """The last few inputs and outputs of a row-wise function, to work out only the rows an input changed.

    Parameters
    ----------
    pieces : callable
        ``pieces(segments, key) -> (owner, t0, t1)``: the pieces each row of
        ``segments`` makes (``Segments.split``), ``owner`` sorted; ``key``
        names everything else they depend on.
    size : int
        Inputs kept (weakly: an entry goes with its input or output).
    """

    def __init__(self, pieces: Callable[[Segments, object], tuple[np.ndarray, np.ndarray, np.ndarray]],
                 size: int = 4) -> None:
        self._pieces, self._size = pieces, size
        self._entries: list[tuple] = []  # (key, weak parts, weak output, starts), most recent first
        #: Rows worked out by the last call (for tests and benchmarks).
        self.computed_rows = 0

    def __call__(self, parts: Sequence[Segments], key: object) -> Segments:
        """``pieces`` of the rows of ``parts`` (concatenated), taken from a kept output where the rows match."""
        parts = list(parts)
        rows = sum(len(part) for part in parts)
        kept = [(entry, [part() for part in entry[1]], entry[2]()) for entry in self._entries]
        best = Blocks.of([rows], [-1]), empty_segments(), np.zeros(1, np.int64)
        for (old_key, _, _, old_starts), old_parts, old_output in kept:
            if old_key != key or old_output is None or len(old_parts) != len(parts) or any(
                    part is None for part in old_parts):
                continue
            blocks = _joined([reused_rows(a, b) for a, b in zip(old_parts, parts)], old_parts, parts)
            if blocks.taken > best[0].taken:
                best = blocks, old_output, old_starts
            if 8 * (rows - blocks.taken) <= rows:
                break
        output, starts = self._spliced(parts, *best, key)
        self._entries = [(key, [weakref.ref(part) for part in parts], weakref.ref(output), starts)] + [
            entry for entry in self._entries if entry[2]() is not None and entry[2]() is not output
        ][:self._size - 1]
        return output

    def _spliced(self, parts: list[Segments], blocks: Blocks, old: Segments, old_starts: np.ndarray,
                 key: object) -> tuple[Segments, np.ndarray]:
        """The output of ``parts`` from an earlier one, ``old``: the rows ``blocks`` does not take worked out."""
        changed = blocks.fresh_rows()
        offsets = np.cumsum([0] + [len(part) for part in parts])
        rows = concatenate([empty_segments()] + [part.take(changed[(changed >= a) & (changed < b)] - a)
                                                 for part, a, b in zip(parts, offsets[:-1], offsets[1:])])
        owner, t0, t1 = self._pieces(rows, key)
        self.computed_rows = len(rows)
        return splice(old, old_starts, blocks, rows.split(owner, t0, t1), row_starts(owner, len(rows)))


def _joined(blocks: list[Blocks], old_parts: list[Segments], parts: list[Segments]) -> Blocks:
    """The blocks of each part, as blocks of the parts one after the other."""
    old_offsets = np.cumsum([0] + [len(part) for part in old_parts])
    return Blocks.of(np.concatenate([part.length for part in blocks]),
                     np.concatenate([np.where(part.source >= 0, part.source + offset, -1)
                                     for part, offset in zip(blocks, old_offsets)]))
