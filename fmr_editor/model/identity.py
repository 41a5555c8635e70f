"""Stable ids for the items of a document (curves and points).

An item keeps its id through every edit (``dataclasses.replace`` carries it
over), so edits, the selection and the engine address items by id rather
than by position, which insertions, deletions and reordering change.  Ids
are not part of an item's value: two curves with the same geometry and
colours are equal whatever their ids.  They are unique among the items made
in one process, which is why they come from one counter rather than from
each document: an item may travel between documents (undo, copy and paste)
and must not meet another with its id there.  Files do not store them; an
item read from a file gets a new one.
"""

from __future__ import annotations

import itertools

_counter = itertools.count(1)


def new_id() -> int:
    """An id no item of this process has had."""
    return next(_counter)


def checked_id(value: object) -> int:
    """``value`` as an item id (a positive int); a fresh id for None."""
    if value is None:
        return new_id()
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"an item id must be a positive whole number, got {value!r}")
    return value
