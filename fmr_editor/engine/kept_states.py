"""The states of recent steps, kept so that undo and redo return to them at once.

A ``LiveRepresentation`` never changes an array it has made (updates make
new ones), so keeping a state is keeping references: what costs memory is
the arrays no later state shares.  ``KeptStates`` holds the newest states up
to a memory budget and finds a state by its document (the very object:
a history hands the same ``Document`` back on undo).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from ..model import Document
from .cells import Cells
from .fmm.lattice import Lattice
from .geometry.segments import Segments
from .points.field import LivePoints

#: Bytes the states of recent steps may take by default (a document's undo memory).
DEFAULT_MEMORY = 500 * 2**20


@dataclass(frozen=True, eq=False)
class State:
    """Everything a ``LiveRepresentation``'s representation of one document is made of."""

    document: Document
    lattice: Lattice
    curves: Segments
    radii: np.ndarray
    boundary: Segments
    unknowns: np.ndarray
    cells: Cells
    points: LivePoints | None

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays the state holds (shared ones counted in every state that holds them)."""
        points = self.points.nbytes if self.points is not None else 0
        return (self.radii.nbytes + self.unknowns.nbytes + self.curves.nbytes + self.boundary.nbytes
                + self.cells.nbytes + points)


class KeptStates:
    """The newest states, at most ``memory`` bytes of them (the newest is always kept).

    Parameters
    ----------
    memory : int
    """

    def __init__(self, memory: int) -> None:
        self.memory = int(memory)
        self._states: OrderedDict[int, State] = OrderedDict()
        self._bytes: dict[int, int] = {}

    def keep(self, state: State) -> None:
        key = id(state.document)
        self._states.pop(key, None)
        self._states[key] = state
        self._bytes[key] = state.nbytes
        while len(self._states) > 1 and sum(self._bytes.values()) > self.memory:
            oldest, _ = self._states.popitem(last=False)
            del self._bytes[oldest]

    def find(self, document: Document) -> State | None:
        """The kept state of ``document`` (this very object), or None."""
        state = self._states.get(id(document))
        return state if state is not None and state.document is document else None

    def clear(self) -> None:
        self._states.clear()
        self._bytes.clear()

    def __len__(self) -> int:
        return len(self._states)
