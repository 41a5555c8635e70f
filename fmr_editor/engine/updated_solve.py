"""The boundary system after a geometry edit, solved with the factorisation of the system before it.

A geometry edit replaces a few segments: of the base system's segments
(the geometry that was factorised) some are kept (K), some removed (R), and
the new geometry adds others (A).  Ordering both systems kept-first,

    A0 = [[A_KK, A_KR], [A_RK, A_RR]],   A1 = [[A_KK, A_KA], [A_AK, A_AA]],

and the entries among kept segments are the same in both (an entry depends
only on its two segments).  With G = A0^-1 (the base factorisation, applied
by ``BoundarySolver.solve``), the kept block's inverse is a Schur complement
of G (G_KR, G_RR: G applied to the unit vectors of R):

    A_KK^-1 v = (G [v; 0])_K - G_KR G_RR^-1 (G [v; 0])_R,

and A1 is A_KK bordered by the added segments, solved through the Schur
complement S = A_AA - A_AK A_KK^-1 A_KA.  Setting up costs base solves for
|R| + |A| columns (those for R are cached by segment, so a drag that keeps
replacing the same segments pays them once) and ``2 |A| n`` matrix entries;
each solve after that is one base solve plus small dense products.

With a dense (exact) base the result is exact; with the compressed one it is
as accurate as that factorisation, which is why ``LiveRepresentation`` takes
one defect-correction step through an FMM product (``correct``).
``solve_reference`` is the plain dense solve of the new system to test against.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .bem import assemble
from .fast_solve import BoundarySolver, CollocationOperator
from .lattice import Lattice, sort_into_cells
from .segments import Segments
from .skeleton import CollocationEntries

#: Reciprocal condition number below which a small factor of the update counts as singular: the new
#: system is then (nearly) singular itself and is left to a fresh factorisation, which handles that.
MIN_CONDITION = 1e-10

#: Replaced segments (removed + added, against the factorised geometry) above which a new
#: factorisation is cheaper than the update's set-up and its per-solve products.
MAX_REPLACED = 600


def match_segments(old: Segments, new: Segments) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of identical segments (end points and border flag): indices into ``old`` and ``new``.

    Each segment is matched at most once, in order among equal ones.
    """
    def keys(segments: Segments) -> np.ndarray:
        rows = np.ascontiguousarray(np.column_stack([segments.p, segments.q, segments.on_border]), np.float64)
        return rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()

    old_keys, new_keys = keys(old), keys(new)
    order = np.argsort(old_keys, kind="stable")
    ranked = old_keys[order]
    first = np.searchsorted(ranked, new_keys)
    last = np.searchsorted(ranked, new_keys, side="right")
    found = np.flatnonzero(last > first)
    # the k-th of equal new segments takes the k-th of equal old ones
    groups = np.unique(new_keys[found], return_inverse=True)[1]
    rank_in_group = np.zeros(len(found), np.int64)
    if len(found):
        sorted_groups = np.argsort(groups, kind="stable")
        starts = np.searchsorted(groups[sorted_groups], groups[sorted_groups])
        rank_in_group[sorted_groups] = np.arange(len(found)) - starts
    slot = first[found] + rank_in_group
    ok = slot < last[found]
    return order[slot[ok]], found[ok]


def updated_solver(base: BoundarySolver, base_segments: Segments, segments: Segments, lattice: Lattice,
                   columns: dict[int, np.ndarray] | None = None,
                   max_replaced: int = MAX_REPLACED) -> UpdatedSolver | None:
    """An ``UpdatedSolver`` for ``segments``, or None when a new factorisation is the better choice.

    That is when ``base`` holds no curves (its system is trivial), when
    ``segments`` hold none (theirs is), or when more than ``max_replaced``
    segments differ from ``base_segments``.
    """
    if base.trivial or base.least_squares or not np.any(~segments.on_border):
        return None
    kept_base, kept = match_segments(base_segments, segments)
    if base.size - len(kept) + len(segments) - len(kept) > max_replaced:
        return None
    try:
        return UpdatedSolver(base, segments, lattice, kept_base, kept, columns)
    except np.linalg.LinAlgError:
        return None


def _factors(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LU factors of ``matrix``; ``LinAlgError`` when it is singular to ``MIN_CONDITION``."""
    norm = float(np.abs(matrix).sum(axis=0).max(initial=0.0))
    lu, pivots = scipy.linalg.lu_factor(matrix, check_finite=False)
    condition, _ = scipy.linalg.lapack.dgecon(lu, norm, norm="1")
    if not condition >= MIN_CONDITION:
        raise np.linalg.LinAlgError(f"singular to {condition:.1e}")
    return lu, pivots


class UpdatedSolver:
    """The boundary system of ``segments``, solved through ``base``'s factorisation of a nearby geometry.

    Offers what ``LiveRepresentation`` asks of a ``BoundarySolver``
    (``right_hand_side``, ``solve``, ``accuracy``) plus ``correct``; made by
    ``updated_solver``.

    Parameters
    ----------
    base : BoundarySolver
        Factorised for a geometry ``base_segments`` (not trivial).
    segments : Segments
        The new geometry (its input order is this solver's).
    lattice : Lattice
        Lattice for the FMM products.
    kept_base, kept : numpy.ndarray
        ``match_segments(base_segments, segments)``.
    columns : dict, optional
        Cache of ``base`` applied to unit vectors, by base index; filled here
        and reusable by the next ``UpdatedSolver`` of the same base.
    """

    def __init__(self, base: BoundarySolver, segments: Segments, lattice: Lattice, kept_base: np.ndarray,
                 kept: np.ndarray, columns: dict[int, np.ndarray] | None = None) -> None:
        self.base, self.size, self.trivial, self.dense = base, len(segments), False, base.dense
        self.kept_base, self.kept = kept_base, kept
        self.removed = np.setdiff1d(np.arange(base.size), kept_base)
        self.added = np.setdiff1d(np.arange(len(segments)), kept)
        cells = lattice.cell_of(segments.midpoints)
        self.order = np.argsort(cells[:, 0] * lattice.cells_per_side + cells[:, 1], kind="stable")
        ordered, cell_start = sort_into_cells(segments, lattice)
        self.operator = CollocationOperator(ordered, cell_start, lattice, order=base.operator.order)
        self._removed_columns(columns if columns is not None else {})
        entries = CollocationEntries(segments)
        added = self.added
        self._kept_to_added = entries.block(kept, added)  # A_KA
        self._added_to_kept = entries.block(added, kept)  # A_AK
        self._z = self._kept_solve(self._kept_to_added)  # A_KK^-1 A_KA
        schur = entries.block(added, added) - self._added_to_kept @ self._z
        self._schur = _factors(schur) if len(added) else None

    def _removed_columns(self, cache: dict[int, np.ndarray]) -> None:
        """G applied to the unit vectors of the removed segments (G_:R), and G_RR's factors."""
        missing = [r for r in self.removed.tolist() if r not in cache]
        if missing:
            units = np.zeros((self.base.size, len(missing)))
            units[missing, np.arange(len(missing))] = 1.0
            for r, column in zip(missing, self.base.solve(units, iterate=False).T):
                cache[r] = column
        self._g_r = np.column_stack([cache[r] for r in self.removed.tolist()]) if len(self.removed) \
            else np.zeros((self.base.size, 0))
        self._g_rr = _factors(self._g_r[self.removed]) if len(self.removed) else None

    def _kept_solve(self, values: np.ndarray) -> np.ndarray:
        """``A_KK^-1 values`` for ``values`` of shape ``(len(kept), m)``."""
        embedded = np.zeros((self.base.size, values.shape[1]))
        embedded[self.kept_base] = values
        solved = self.base.solve(embedded, iterate=False)
        kept = solved[self.kept_base]
        if self._g_rr is not None:
            kept -= self._g_r[self.kept_base] @ scipy.linalg.lu_solve(self._g_rr, solved[self.removed],
                                                                      check_finite=False)
        return kept

    def solve(self, rhs: np.ndarray, progress=None, iterate: bool = False) -> np.ndarray:
        """Unknowns ``(n, m)`` for ``rhs (n, m)`` (this solver's input order), as accurate as the base factors."""
        w = self._kept_solve(rhs[self.kept])
        out = np.empty_like(rhs, dtype=float)
        if self._schur is not None:
            added = scipy.linalg.lu_solve(self._schur, rhs[self.added] - self._added_to_kept @ w, check_finite=False)
            out[self.added] = added
            w = w - self._z @ added
        out[self.kept] = w
        return out

    def right_hand_side(self, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """As ``BoundarySolver.right_hand_side``."""
        rhs = self.operator.right_hand_side(jump[self.order], mean[self.order])
        out = np.empty_like(rhs)
        out[self.order] = rhs
        return out

    def residual(self, unknown: np.ndarray, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """``rhs - A unknown`` for colours ``jump``, ``mean`` (input order), in one FMM product."""
        operator, order = self.operator, self.order
        border = operator.border
        x = unknown[order]
        curve_jump = np.where(border, 0.0, jump[order])
        field = operator.field(np.where(border, 0.0, x), curve_jump + np.where(border, x, 0.0))
        sorted_residual = np.where(border, 0.5 * x, mean[order]) - field
        out = np.empty_like(sorted_residual)
        out[order] = sorted_residual
        return out

    def correct(self, initial: np.ndarray, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """One defect-correction step from ``initial``: ``x + solve(rhs - A x)`` (one FMM product)."""
        return initial + self.solve(self.residual(initial, jump, mean))

    def accuracy(self, iterate: bool = True) -> float:
        """Relative accuracy of ``solve`` (the base factorisation's; ``correct`` does better)."""
        return self.base.accuracy(iterate=False)


def carried_unknowns(old: Segments, unknowns: np.ndarray, new: Segments) -> np.ndarray:
    """``old``'s solved ``unknowns (n, 3)`` carried over to the geometry ``new``: the old densities.

    Identical segments keep their values; any other segment of a curve takes
    the value of the old segment of the same curve nearest along it
    (``Segments.origin``), so a moved piece keeps the densities it had; the
    rest start at 0.  A drag's preview shows this without a solve, and it
    is where ``UpdatedSolver.correct`` starts from.
    """
    out = np.zeros((len(new), unknowns.shape[1]))
    kept_old, kept = match_segments(old, new)
    out[kept] = unknowns[kept_old]
    loose = np.setdiff1d(np.flatnonzero(~new.on_border), kept)
    sources = np.flatnonzero(~old.on_border)
    if len(loose) == 0 or len(sources) == 0:
        return out
    span = float(np.nanmax(np.abs(np.concatenate([old.origin[:, 1], new.origin[:, 1]])), initial=0.0)) + 1.0
    def position(segments: Segments, index: np.ndarray) -> np.ndarray:  # curve, then place along it
        curve, place = segments.origin[index, 0], np.nan_to_num(segments.origin[index, 1])
        return curve * 4 * span + place
    keys = position(old, sources)
    order = np.argsort(keys)
    keys, sources = keys[order], sources[order]
    wanted = position(new, loose)
    right = np.clip(np.searchsorted(keys, wanted), 1, len(keys) - 1) if len(keys) > 1 else np.zeros(len(loose), int)
    left = np.maximum(right - 1, 0)
    nearest = np.where(np.abs(keys[left] - wanted) <= np.abs(keys[right] - wanted), left, right)
    same_curve = old.origin[sources[nearest], 0] == new.origin[loose, 0]
    out[loose[same_curve]] = unknowns[sources[nearest[same_curve]]]
    return out


def solve_reference(segments: Segments) -> np.ndarray:
    """The unknowns ``(n, 3)`` of ``segments``' system by a dense solve (plain; for tests)."""
    matrix, rhs = assemble(segments)
    return np.linalg.solve(matrix, rhs)
