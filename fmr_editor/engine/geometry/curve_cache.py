"""A document's curves as clipped segments, kept from one edit to the next.

``discretise.curve_segments`` flattens every curve, clips it to the canvas and
lets later segments keep collinear overlaps (``overlaps``); that last step
searches the whole set.  An edit changes a few curves, so ``CurveSegments``
keeps each curve's flattened and clipped segments and the overlapping pairs
it found last time: the pairs among untouched curves stay, and only pairs
with a segment of a new or changed curve are searched for.  Its result
equals ``curve_segments``'s (tested).
"""

from __future__ import annotations

import numpy as np

from ...model import DiffusionCurve, Document
from ...model.limits import LimitError
from ..memory import check_build_memory
from .discretise import clip_to_canvas, from_curve
from .flatten import flatten_curves, flattened_count
from .overlaps import drop_covered_parts, overlapping_pairs
from .segments import Segments, concatenate, empty_segments


#: Most segments the curves of a document may be flattened into (roses: 70,000).
MAX_SEGMENTS = 2_000_000


class CurveSegments:
    """``curve_segments`` of one document after another, reusing what an edit left alone.

    Parameters
    ----------
    tolerance, max_length : float
        As for ``discretise.curve_segments``.
    """

    def __init__(self, tolerance: float, max_length: float) -> None:
        self.tolerance, self.max_length = tolerance, max_length
        self._clipped: dict[tuple[DiffusionCurve, float, float], Segments] = {}
        # the last document's (curves, canvas, segments per curve, pairs, twins among them)
        self._last: tuple | None = None

    def _clip(self, curves: tuple[DiffusionCurve, ...], width: float, height: float) -> list[Segments]:
        """Each of ``curves`` flattened and clipped: kept ones as they were, the others all at once."""
        new = list(dict.fromkeys(curve for curve in curves if (curve, width, height) not in self._clipped))
        for curve, flat in zip(new, flatten_curves(new, self.tolerance, self.max_length)):
            self._clipped[(curve, width, height)] = clip_to_canvas(flat, width, height)
        return [self._clipped[(curve, width, height)] for curve in curves]

    def copy(self) -> CurveSegments:
        """An independent cache holding what this one holds (the segments themselves shared: they never change)."""
        twin = CurveSegments(self.tolerance, self.max_length)
        twin._clipped, twin._last = dict(self._clipped), self._last
        return twin

    def forget(self, keep: tuple[DiffusionCurve, ...]) -> None:
        """Drop the kept segments of curves in neither ``keep`` nor the last document."""
        wanted = set(keep) | set(self._last[0] if self._last is not None else ())
        self._clipped = {key: value for key, value in self._clipped.items() if key[0] in wanted}

    def segments(self, document: Document) -> Segments:
        """The document's curve segments, as ``segments.curve_segments(document, tolerance, max_length)``."""
        canvas = (float(document.width), float(document.height))
        self._check_size(document.curves, canvas)
        pieces = self._clip(document.curves, *canvas)
        counts = np.array([len(piece) for piece in pieces], np.int64)
        clipped = concatenate([empty_segments(), *pieces])
        clipped = from_curve(clipped, 0)
        clipped.origin[:, 0] = np.repeat(np.array([curve.id for curve in document.curves], np.float64), counts)
        pairs = self._pairs(document.curves, canvas, counts, clipped)
        self._last = (document.curves, canvas, counts, pairs, _has_twins(clipped, pairs))
        return drop_covered_parts(clipped, pairs=pairs)

    def _check_size(self, curves: tuple[DiffusionCurve, ...], canvas: tuple[float, float]) -> None:
        """Refuse ``curves`` that would make more segments than the limit or the memory allow, before the new
        ones are flattened."""
        kept = [self._clipped.get((curve, *canvas)) for curve in curves]
        new = [curve for curve, segments in zip(curves, kept) if segments is None]
        count = sum(len(segments) for segments in kept if segments is not None)
        count += flattened_count(new, self.tolerance, self.max_length)
        if count > MAX_SEGMENTS:
            raise LimitError(f"the curves make about {count:,} segments, more than the {MAX_SEGMENTS:,} allowed")
        check_build_memory(count, 2)

    def _pairs(self, curves: tuple, canvas: tuple, counts: np.ndarray, clipped: Segments):
        """The overlapping pairs of ``clipped``: those among curves kept from the last document, plus new ones."""
        last = self._last
        if last is None or last[1] != canvas or last[4]:
            # repeated segments only pair with their last twin: search everything again when there were some
            return overlapping_pairs(clipped)
        last_curves, _, last_counts, last_pairs, _ = last
        position = {id(curve): i for i, curve in enumerate(last_curves)}
        was = np.array([position.get(id(curve), -1) for curve in curves], np.int64)
        kept = was[was >= 0]
        if len(position) != len(last_curves) or np.any(np.diff(kept) <= 0):
            return overlapping_pairs(clipped)  # a curve twice, or curves reordered: search everything
        starts, last_starts = np.cumsum(counts) - counts, np.cumsum(last_counts) - last_counts
        moved_to = np.full(int(last_counts.sum()), -1, np.int64)  # each old segment's index now, -1: gone
        for i in np.flatnonzero(was >= 0):
            j = was[i]
            moved_to[last_starts[j]: last_starts[j] + counts[i]] = starts[i] + np.arange(counts[i])
        earlier, later = moved_to[last_pairs[0]], moved_to[last_pairs[1]]
        still = (earlier >= 0) & (later >= 0)
        fresh = np.repeat(was < 0, counts)
        found = overlapping_pairs(clipped, among=fresh) if fresh.any() else tuple(np.zeros(0, a.dtype)
                                                                                for a in last_pairs)
        return tuple(np.concatenate([kept_values, new_values]) for kept_values, new_values in
                     zip((earlier[still], later[still], last_pairs[2][still], last_pairs[3][still]), found))


def _has_twins(segments: Segments, pairs: tuple) -> bool:
    """Whether ``pairs`` (of ``segments``) hold two segments with the same end points (``overlaps.last_twins``)."""
    p, q = segments.p, segments.q
    earlier, later = pairs[0], pairs[1]

    def equal(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.all(a[earlier] == b[later], axis=1)

    return bool(np.any((equal(p, p) & equal(q, q)) | (equal(p, q) & equal(q, p))))
