"""What changed between two documents: the engine's cue for what to update.

Every change to a document, undo and redo included, is a pair of documents
``(before, after)``; ``ChangeSet.between`` describes the difference.  Items
are matched by value (curves and points are immutable), so an item that
appears in both documents, in whatever position, is unchanged.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from .document import Document


def _unmatched(before: tuple, after: tuple) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Indices of items in ``before`` without a match in ``after`` and vice versa (multiset difference).

    Items that are the very same objects at the head and the tail of both
    match without hashing (an edit replaces a few curves of thousands): only
    what lies between is compared by value.
    """
    if len(after) >= len(before) and after[: len(before)] == before:  # appended (a brush dab): no hashing
        return (), tuple(range(len(before), len(after)))
    shortest, head, tail = min(len(before), len(after)), 0, 0
    while head < shortest and before[head] is after[head]:
        head += 1
    while tail < shortest - head and before[-1 - tail] is after[-1 - tail]:
        tail += 1
    removed, added = _difference(before[head: len(before) - tail], after[head: len(after) - tail])
    return tuple(head + index for index in removed), tuple(head + index for index in added)


def _difference(before: tuple, after: tuple) -> tuple[list[int], list[int]]:
    """``_unmatched`` by counting every item's copies (hashing all of them)."""
    spare = Counter(after) - Counter(before)  # items after has more of
    missing = Counter(before) - Counter(after)
    removed, added = [], []
    for index, item in enumerate(before):
        if missing[item]:
            missing[item] -= 1
            removed.append(index)
    for index, item in enumerate(after):
        if spare[item]:
            spare[item] -= 1
            added.append(index)
    return removed, added


@dataclass(frozen=True)
class ChangeSet:
    """The difference between two documents.

    Attributes
    ----------
    canvas_changed : bool
        The canvas size differs.
    curves_changed : bool
        The curves differ in content or order (drawing order decides which
        of two overlapping curves keeps the overlap).
    removed_curves, added_curves : tuple of int
        Indices of curves in ``before`` missing from ``after``, and of curves
        in ``after`` new to it.
    removed_points, added_points : tuple of int
        The same for diffusion points (their order does not matter).
    """

    canvas_changed: bool
    curves_changed: bool
    removed_curves: tuple[int, ...]
    added_curves: tuple[int, ...]
    removed_points: tuple[int, ...]
    added_points: tuple[int, ...]

    @classmethod
    def between(cls, before: Document, after: Document) -> ChangeSet:
        """Describe how ``after`` differs from ``before``."""
        canvas = (before.width, before.height) != (after.width, after.height)
        same_curves = before.curves is after.curves or before.curves == after.curves
        removed_curves, added_curves = ((), ()) if same_curves else _unmatched(before.curves, after.curves)
        same_points = before.points is after.points
        removed_points, added_points = ((), ()) if same_points else _unmatched(before.points, after.points)
        return cls(canvas, not same_curves, removed_curves, added_curves, removed_points, added_points)

    @property
    def empty(self) -> bool:
        """True when the two documents are equal."""
        return not (self.canvas_changed or self.curves_changed or self.removed_points or self.added_points)


def recoloured_curves(before: Document, after: Document, changes: ChangeSet) -> tuple[int, ...] | None:
    """Ids of the curves whose stops changed colour and nothing else, or None for any other change.

    The engine keeps the boundary system's factorisation for such an edit
    (its geometry is the same).  A recoloured curve keeps its id and its
    place; every other curve is the same.
    """
    replaced = changes.added_curves
    if len(before.curves) != len(after.curves) or changes.removed_curves != replaced:
        return None
    for index in replaced:
        old, new = before.curves[index], after.curves[index]
        if not (old.id == new.id and np.array_equal(old.control_points, new.control_points)
                and [s.position for s in old.left] == [s.position for s in new.left]
                and [s.position for s in old.right] == [s.position for s in new.right]):
            return None
    chosen = set(replaced)
    unchanged = tuple(before.curves[i] if i in chosen else curve for i, curve in enumerate(after.curves))
    return tuple(after.curves[i].id for i in replaced) if unchanged == before.curves else None
