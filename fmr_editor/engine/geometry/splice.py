"""Row-wise results kept between edits: the pieces of unchanged rows taken over, only changed rows worked out.

Cutting segments at cell edges (``discretise.cut_at_cells``), dropping their
covered parts (``overlaps.drop_covered_parts``) and clipping curves make each
input row's pieces from that row alone (and from data the caller tracks), and
put them out row after row in input order.  So after an edit that changed a
few rows, the output is the old output with the pieces of those rows replaced:
``splice`` assembles it from slices, ``reused_rows`` finds which rows of a new
input equal (bit for bit) rows of an old one, and ``RowCache`` keeps the last
few inputs and outputs of such a row-wise function for callers that know
nothing of the edit.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Sequence

import numpy as np

from .segments import _FIELDS, Segments, concatenate, empty_segments


def row_starts(owner: np.ndarray, rows: int) -> np.ndarray:
    """Where each of ``rows`` rows' pieces start among pieces whose rows are ``owner`` (sorted); ``rows + 1``
    entries, the last the number of pieces."""
    return np.searchsorted(owner, np.arange(rows + 1)).astype(np.int64)


def splice(old: Segments, old_starts: np.ndarray, reuse: np.ndarray, fresh: Segments,
           fresh_starts: np.ndarray, fields: Sequence[str] = _FIELDS) -> tuple[Segments | tuple, np.ndarray]:
    """The pieces of rows some of which come from an earlier output, in row order.

    Parameters
    ----------
    old : Segments
        The earlier output; old row ``k`` made the pieces ``old_starts[k]:old_starts[k + 1]``.
    old_starts : numpy.ndarray
    reuse : numpy.ndarray
        ``(n,)`` for each row, the old row whose pieces it takes, or -1 for a row worked out anew.
    fresh : Segments
        The pieces of the rows worked out anew, in row order; the ``j``-th such row made
        ``fresh_starts[j]:fresh_starts[j + 1]``.
    fresh_starts : numpy.ndarray
    fields : sequence of str
        All of ``Segments``'s (the default), or only these, returned as a tuple of arrays.

    Returns
    -------
    pieces : Segments or tuple of numpy.ndarray
    starts : numpy.ndarray
        ``(n + 1,)`` where each row's pieces start in ``pieces``.
    """
    reuse = np.asarray(reuse, np.int64)
    is_fresh = reuse < 0
    counts = np.empty(len(reuse), np.int64)
    counts[~is_fresh] = np.diff(old_starts)[reuse[~is_fresh]]
    counts[is_fresh] = np.diff(fresh_starts)
    starts = np.concatenate([[0], np.cumsum(counts)])
    whole = fields is _FIELDS
    if is_fresh.all():
        source = fresh
    elif not is_fresh.any() and len(reuse) == len(old_starts) - 1 and np.all(reuse == np.arange(len(reuse))):
        source = old
    else:
        source = None
    if source is not None:
        return (source if whole else tuple(getattr(source, name) for name in fields)), starts
    # runs of rows taken from one source without a gap: one slice each
    fresh_rank = np.cumsum(is_fresh) - is_fresh
    cut = np.ones(len(reuse), bool)
    cut[1:] = (is_fresh[1:] != is_fresh[:-1]) | (~is_fresh[1:] & (reuse[1:] != reuse[:-1] + 1))
    first = np.flatnonzero(cut)
    last = np.append(first[1:], len(reuse)) - 1
    slices = []
    for a, b in zip(first.tolist(), last.tolist()):
        if is_fresh[a]:
            slices.append((fresh, fresh_starts[fresh_rank[a]], fresh_starts[fresh_rank[b] + 1]))
        else:
            slices.append((old, old_starts[reuse[a]], old_starts[reuse[b] + 1]))
    arrays = tuple(np.concatenate([getattr(source, name)[a:b] for source, a, b in slices]) for name in fields)
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


def reused_rows(old: Segments, new: Segments) -> np.ndarray:
    """For each row of ``new``, a row of ``old`` with the same bits in every field, or -1.

    Rows are matched in place when both have one length (any rows may
    differ), else by the longest common start and end.
    """
    if new is old:
        return np.arange(len(new))
    if len(new) == len(old):
        reuse = np.arange(len(new))
        reuse[differing_rows(old, new)] = -1
        return reuse
    m = min(len(old), len(new))
    head = differing_rows(old, new, slice(0, m), slice(0, m))
    start = int(head[0]) if len(head) else m
    tail = differing_rows(old, new, slice(len(old) - m + start, len(old)), slice(len(new) - m + start, len(new)))
    end = m - start - 1 - int(tail[-1]) if len(tail) else m - start
    reuse = np.full(len(new), -1, np.int64)
    reuse[:start] = np.arange(start)
    reuse[len(new) - end:] = np.arange(len(old) - end, len(old))
    return reuse


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
        self._lock = threading.Lock()
        #: Rows worked out by the last call (for tests and benchmarks).
        self.computed_rows = 0

    def __call__(self, parts: Sequence[Segments], key: object) -> Segments:
        """``pieces`` of the rows of ``parts`` (concatenated), taken from a kept output where the rows match."""
        parts = list(parts)
        with self._lock:
            kept = [(entry, [part() for part in entry[1]], entry[2]()) for entry in self._entries]
        kept = [(entry[0], old_parts, output, entry[3]) for entry, old_parts, output in kept
                if output is not None and all(part is not None for part in old_parts)]
        best = None
        for old_key, old_parts, old_output, old_starts in kept:
            if old_key != key or len(old_parts) != len(parts):
                continue
            offsets = np.cumsum([0] + [len(part) for part in old_parts])
            reuse = np.concatenate([np.where(rows >= 0, rows + offset, -1) for rows, offset in
                                    zip((reused_rows(a, b) for a, b in zip(old_parts, parts)), offsets)])
            if best is None or (reuse >= 0).sum() > (best[0] >= 0).sum():
                best = reuse, old_output, old_starts
            if (reuse < 0).sum() * 8 <= len(reuse):
                break
        if best is None:
            best = np.full(sum(len(part) for part in parts), -1, np.int64), empty_segments(), np.zeros(1, np.int64)
        output, starts = self._spliced(parts, *best, key)
        with self._lock:
            self._entries = [(key, [weakref.ref(part) for part in parts], weakref.ref(output), starts)] + [
                entry for entry in self._entries if entry[2]() is not None and entry[2]() is not output
            ][:self._size - 1]
        return output

    def _spliced(self, parts: list[Segments], reuse: np.ndarray, old: Segments, old_starts: np.ndarray,
                 key: object) -> tuple[Segments, np.ndarray]:
        """The output of ``parts`` from an earlier one, ``old``: the rows with ``reuse`` -1 worked out anew."""
        changed = np.flatnonzero(reuse < 0)
        offsets = np.cumsum([0] + [len(part) for part in parts])
        rows = concatenate([empty_segments()] + [part.take(changed[(changed >= a) & (changed < b)] - a)
                                                 for part, a, b in zip(parts, offsets[:-1], offsets[1:])])
        owner, t0, t1 = self._pieces(rows, key)
        self.computed_rows = len(rows)
        return splice(old, old_starts, reuse, rows.split(owner, t0, t1), row_starts(owner, len(rows)))
