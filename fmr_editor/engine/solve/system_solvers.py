"""The boundary system's solver for the current geometry, made through a kept factorisation.

Factorising the system is the expensive part of a solve.  ``SystemSolvers``
keeps one factorisation (the *base*) and answers each later geometry with an
``updated.UpdatedSolver`` of it, made only when first asked for; when
the geometry has moved too far from the base (``updated_solver`` declines)
or the update turns out singular, it factorises the current geometry and
that becomes the base.
"""

from __future__ import annotations

import hashlib
import weakref
from collections.abc import Callable

import numpy as np

from ..geometry.segments import Segments
from .solver import BoundarySolver
from .updated import UpdatedSolver, updated_solver

Solver = BoundarySolver | UpdatedSolver
Factorise = Callable[[Segments], BoundarySolver]


class SharedFactorisations:
    """Factorisations held by any representation, found again by their geometry.

    A translucent layer's image and alpha field are diffusions on the same curves: their boundary systems
    are one matrix (``BoundarySolver`` reads the geometry, never the colours), so the second field takes the
    first one's factorisation instead of repeating it.  A factorisation is kept here only while some
    ``SystemSolvers`` holds it (weakly: this costs no memory).
    """

    def __init__(self) -> None:
        self._held: weakref.WeakValueDictionary[bytes, BoundarySolver] = weakref.WeakValueDictionary()

    @staticmethod
    def key(boundary: Segments, lattice_levels: int, side: float) -> bytes:
        """What the system depends on: the segments' end points and border flags, and the products' lattice."""
        digest = hashlib.blake2b(digest_size=20)
        for array in (boundary.p, boundary.q, boundary.on_border):
            digest.update(np.ascontiguousarray(array).tobytes())
        digest.update(np.array([lattice_levels, side]).tobytes())
        return digest.digest()

    def get(self, key: bytes) -> BoundarySolver | None:
        return self._held.get(key)

    def keep(self, key: bytes, solver: BoundarySolver) -> None:
        self._held[key] = solver


class SystemSolvers:
    """The current geometry's solver: the base factorisation or an update of it.

    Parameters
    ----------
    factorise : callable
        ``factorise(boundary) -> BoundarySolver`` for a geometry.
    """

    def __init__(self, factorise: Factorise) -> None:
        self._factorise = factorise
        self.reset(None, None)

    def reset(self, base: BoundarySolver | None, boundary: Segments | None) -> None:
        """Take ``base``, the factorisation of ``boundary``, as the current solver (None: none yet)."""
        self._base, self._base_boundary, self._current, self._boundary = base, boundary, base, boundary
        self._columns: dict[int, np.ndarray] = {}  # the base applied to unit vectors, by segment (``updated``)

    def move_to(self, boundary: Segments) -> None:
        """Go over to the geometry ``boundary``; its solver is made when first asked for."""
        self._boundary, self._current = boundary, None

    @property
    def current(self) -> Solver:
        if self._current is None:
            self._current = self._made_for(self._boundary)
        return self._current

    def _made_for(self, boundary: Segments) -> Solver:
        base = self._base
        if base is not None:
            solver = updated_solver(base, self._base_boundary, boundary, base.operator.lattice, self._columns)
            if solver is not None:
                removed = set(solver.removed.tolist())
                for r in [r for r in self._columns if r not in removed]:  # in place: the solver fills this dict
                    del self._columns[r]
                return solver
        self.reset(self._factorise(boundary), boundary)
        return self._base

    def run(self, work: Callable[[Solver], np.ndarray]) -> np.ndarray:
        """``work(current)``; an update found singular gives way to a new factorisation, which handles that."""
        try:
            return work(self.current)
        except np.linalg.LinAlgError:
            if not isinstance(self._current, UpdatedSolver):
                raise
        self.reset(self._factorise(self._boundary), self._boundary)
        return work(self._current)

    def solve_geometry(self, initial: np.ndarray) -> np.ndarray:
        """The current geometry's unknowns: corrected from ``initial`` through an update, or solved afresh."""
        boundary = self._boundary

        def solve(solver: Solver) -> np.ndarray:
            if isinstance(solver, UpdatedSolver):
                return solver.correct(initial, boundary.jump, boundary.mean)
            return solver.solve_colours(boundary.jump, boundary.mean)

        return self.run(solve)
