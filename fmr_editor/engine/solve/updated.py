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

import warnings

import numpy as np
import scipy.linalg

from ..fmm.lattice import Lattice, cell_order
from ..geometry.segments import Segments
from .dense import assemble, trivial
from .entries import CollocationEntries
from .solver import BoundarySolver, CollocationOperator, scattered, solved_segments

#: Reciprocal condition number below which a small factor of the update counts as singular: the new
#: system is then (nearly) singular itself and is left to a fresh factorisation, which handles that.
MIN_CONDITION = 1e-10

#: Replaced segments (removed + added, against the factorised geometry) above which a new
#: factorisation is cheaper than the update's set-up and its per-solve products.
MAX_REPLACED = 600


def _others(count: int, taken: np.ndarray, among: np.ndarray | None = None) -> np.ndarray:
    """``range(count)`` (or the sorted ``among``) without ``taken``, in order; no sort, unlike ``setdiff1d``."""
    free = np.ones(count, bool) if among is None else np.zeros(count, bool)
    if among is not None:
        free[among] = True
    free[taken] = False
    return np.flatnonzero(free)


def _rows(segments: Segments, part: slice = slice(None)) -> np.ndarray:
    return np.column_stack([segments.p[part], segments.q[part], segments.on_border[part]]).astype(np.float64)


def _same_rows(old: Segments, new: Segments, old_part: slice, new_part: slice) -> np.ndarray:
    """Whether each of ``old``'s rows ``old_part`` equals ``new``'s ``new_part`` (as many), field by field."""
    return ((old.p[old_part] == new.p[new_part]).all(axis=1) & (old.q[old_part] == new.q[new_part]).all(axis=1)
            & (old.on_border[old_part] == new.on_border[new_part]))


def match_segments(old: Segments, new: Segments) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of identical segments (end points and border flag): indices into ``old`` and ``new``.

    Each segment is matched at most once, in order among equal ones.  An edit
    replaces a run of segments and keeps the order of the rest, so the common
    head and tail are matched by comparing rows in place, and only what lies
    between by sorting (``match_segments_reference``).
    """
    n_old, n_new = len(old), len(new)
    shortest = min(n_old, n_new)
    same = _same_rows(old, new, slice(0, shortest), slice(0, shortest))
    head = int(np.argmin(same)) if not same.all() else shortest
    rest = shortest - head
    same = _same_rows(old, new, slice(n_old - rest, n_old), slice(n_new - rest, n_new))[::-1]
    tail = int(np.argmin(same)) if not same.all() else rest
    old_end, new_end = n_old - tail, n_new - tail
    middle_old, middle_new = _sorted_match(_rows(old, slice(head, old_end)), _rows(new, slice(head, new_end)))
    return (np.concatenate([np.arange(head), head + middle_old, np.arange(old_end, n_old)]),
            np.concatenate([np.arange(head), head + middle_new, np.arange(new_end, n_new)]))


def match_segments_reference(old: Segments, new: Segments) -> tuple[np.ndarray, np.ndarray]:
    """``match_segments`` by sorting everything (plain; for tests)."""
    return _sorted_match(_rows(old), _rows(new))


def _sorted_match(old_rows: np.ndarray, new_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Matched rows of two arrays of rows, by sorting the old rows as bytes and searching the new ones."""
    def keys(rows: np.ndarray) -> np.ndarray:
        rows = np.ascontiguousarray(rows)
        return rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()

    old_keys, new_keys = keys(old_rows), keys(new_rows)
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

    That is when ``base`` holds no curves (its system is trivial) or was
    solved by least squares, when ``segments`` hold none (theirs is
    trivial), or when more than ``max_replaced`` of the segments taking part
    (``solved_segments``: not those as short as a point, which keep E = 0 in
    both systems) differ from ``base_segments``'.
    """
    if base.trivial or base.least_squares or trivial(segments):
        return None
    taking_part = solved_segments(segments)
    kept_base, kept = match_segments(base_segments.take(base.taking_part), segments.take(taking_part))
    kept_base, kept = base.taking_part[kept_base], taking_part[kept]
    if len(base.taking_part) - len(kept) + len(taking_part) - len(kept) > max_replaced:
        return None
    return UpdatedSolver(base, segments, lattice, kept_base, kept, columns)


def _factors(matrix: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """LU factors of ``matrix``; ``LinAlgError`` when it is singular to ``MIN_CONDITION``.

    ``scale`` (a 1-norm, default the matrix's own) is what the matrix's
    smallest singular value is measured against: a Schur complement of a
    singular system is rounding noise, well conditioned in itself but tiny
    next to the blocks it came from.
    """
    norm = float(np.abs(matrix).sum(axis=0).max(initial=0.0))
    with warnings.catch_warnings():  # an exactly singular matrix is what the check below reports
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        lu, pivots = scipy.linalg.lu_factor(matrix, check_finite=False)
    condition, _ = scipy.linalg.lapack.dgecon(lu, norm, norm="1")
    relative = condition * norm / (norm if scale is None else max(scale, 1e-300))
    if not relative >= MIN_CONDITION:
        raise np.linalg.LinAlgError(f"singular to {relative:.1e}")
    return lu, pivots


class UpdatedSolver:
    """The boundary system of ``segments``, solved through ``base``'s factorisation of a nearby geometry.

    Offers what ``LiveRepresentation`` asks of a ``BoundarySolver``
    (``right_hand_side``, ``solve``, ``accuracy``) plus ``correct``; made by
    ``updated_solver``.  Its first solve (or ``correct``) raises
    ``numpy.linalg.LinAlgError`` when the new system is (nearly) singular:
    a fresh factorisation handles that case.

    Parameters
    ----------
    base : BoundarySolver
        Factorised for a geometry ``base_segments`` (not trivial).
    segments : Segments
        The new geometry (its input order is this solver's).
    lattice : Lattice
        Lattice for the FMM products.
    kept_base, kept : numpy.ndarray
        Indices of the segments taking part in both systems (``solved_segments``) that are the same in both,
        into ``base_segments`` and ``segments`` (``match_segments``).
    columns : dict, optional
        Cache of ``base`` applied to unit vectors, by base index; filled here
        and reusable by the next ``UpdatedSolver`` of the same base.
    """

    def __init__(self, base: BoundarySolver, segments: Segments, lattice: Lattice, kept_base: np.ndarray,
                 kept: np.ndarray, columns: dict[int, np.ndarray] | None = None) -> None:
        self.base, self.size, self.trivial, self.dense = base, len(segments), False, base.dense
        self.kept_base, self.kept = kept_base, kept
        taking_part = solved_segments(segments)
        self.removed = _others(base.size, kept_base, base.taking_part)
        self.added = _others(len(segments), kept, taking_part)
        order, cell_start = cell_order(segments.take(taking_part), lattice)
        self.order = taking_part[order]
        ordered = segments.take(self.order)
        self.operator = CollocationOperator(ordered, cell_start, lattice, order=base.operator.order)
        self._columns = columns if columns is not None else {}
        entries = CollocationEntries(segments)
        added = self.added
        self._kept_to_added = entries.block(kept, added)  # A_KA
        self._added_to_kept = entries.block(added, kept)  # A_AK
        self._added_block = entries.block(added, added)  # A_AA
        self._z = self._schur = None  # made by the first solve, in the same base solve as its right-hand side

    def _kept_solve(self, values: np.ndarray) -> np.ndarray:
        """``A_KK^-1 values`` for ``values`` of shape ``(len(kept), m)``: one base solve.

        The first call also solves for what the update itself needs: the
        removed segments' unit vectors not yet cached (G_:R, giving G_RR's
        factors) and A_KA (giving Z = A_KK^-1 A_KA and the Schur complement).

        Raises
        ------
        numpy.linalg.LinAlgError
            When G_RR or the Schur complement is singular (see ``MIN_CONDITION``).
        """
        first = self._z is None
        removed, cache, n = self.removed.tolist(), self._columns, self.base.size
        missing = [r for r in removed if r not in cache] if first else []
        parts = [self._kept_to_added, values] if first else [values]
        embedded = np.zeros((n, len(missing) + sum(part.shape[1] for part in parts)))
        embedded[missing, np.arange(len(missing))] = 1.0
        embedded[self.kept_base, len(missing):] = np.hstack(parts)
        solved = self.base.solve(embedded, iterate=False)
        if first:
            for r, column in zip(missing, solved[:, : len(missing)].T):
                cache[r] = column
            self._g_r = np.column_stack([cache[r] for r in removed]) if removed else np.zeros((n, 0))
            self._g_rr = _factors(self._g_r[self.removed]) if removed else None
        solved = solved[:, len(missing):]
        kept = solved[self.kept_base]
        if self._g_rr is not None:
            kept -= self._g_r[self.kept_base] @ scipy.linalg.lu_solve(self._g_rr, solved[self.removed],
                                                                      check_finite=False)
        if first:
            self._z, kept = kept[:, : len(self.added)], kept[:, len(self.added):]
            schur = self._added_block - self._added_to_kept @ self._z
            scale = float(np.abs(self._added_block).sum(axis=0).max(initial=0.0))
            self._schur = _factors(schur, scale) if len(self.added) else None
        return kept

    def solve(self, rhs: np.ndarray, progress=None, iterate: bool = False) -> np.ndarray:
        """Unknowns ``(n, m)`` for ``rhs (n, m)`` (this solver's input order), as accurate as the base factors."""
        w = self._kept_solve(rhs[self.kept])
        out = np.zeros(rhs.shape)  # 0 on the segments as short as a point
        if self._schur is not None:
            added = scipy.linalg.lu_solve(self._schur, rhs[self.added] - self._added_to_kept @ w, check_finite=False)
            out[self.added] = added
            w = w - self._z @ added
        out[self.kept] = w
        return out

    def right_hand_side(self, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """As ``BoundarySolver.right_hand_side``."""
        return self._unsorted(self.operator.right_hand_side(jump[self.order], mean[self.order]))

    def residual(self, unknown: np.ndarray, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """``rhs - A unknown`` for colours ``jump``, ``mean`` (input order), in one FMM product."""
        operator, order = self.operator, self.order
        border = operator.border
        x = unknown[order]
        curve_jump = np.where(border, 0.0, jump[order])
        field = operator.field(np.where(border, 0.0, x), curve_jump + np.where(border, x, 0.0))
        return self._unsorted(np.where(border, 0.5 * x, mean[order]) - field)

    def correct(self, initial: np.ndarray, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """One defect-correction step from ``initial``: ``x + solve(rhs - A x)`` (one FMM product)."""
        corrected = initial + self.solve(self.residual(initial, jump, mean))
        return self._unsorted(corrected[self.order])  # E = 0 on segments as short as a point, carried or not

    def _unsorted(self, values: np.ndarray) -> np.ndarray:
        return scattered(values, self.order, self.size)

    def accuracy(self, iterate: bool = True) -> float:
        """Relative accuracy of ``solve`` (the base factorisation's; ``correct`` does better)."""
        return self.base.accuracy(iterate=False)


def carried_unknowns(old: Segments, unknowns: np.ndarray, new: Segments) -> np.ndarray:
    """``old``'s solved ``unknowns (n, 3)`` carried over to the geometry ``new``: the old densities.

    Identical segments keep their values; any other segment of a curve takes
    the value of the old segment of the same curve nearest along it
    (``Segments.origin``), so a moved piece keeps the densities it had; the
    rest start at 0.  This is where ``UpdatedSolver.correct`` starts from.
    """
    return carried_unknowns_and_loose(old, unknowns, new)[0]


def carried_unknowns_and_loose(old: Segments, unknowns: np.ndarray,
                               new: Segments) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """``carried_unknowns``, the indices of ``new``'s curve segments that ``old`` does not hold, and
    ``match_segments(old, new)``."""
    out = np.zeros((len(new), unknowns.shape[1]))
    matched = kept_old, kept = match_segments(old, new)
    out[kept] = unknowns[kept_old]
    loose = _others(len(new), np.concatenate([kept, np.flatnonzero(new.on_border)]))
    # the old segments of the loose ones' curves (few curves of many: compare ids, not every segment's place)
    sources = np.flatnonzero(~old.on_border & np.isin(old.origin[:, 0], np.unique(new.origin[loose, 0])))
    if len(loose) == 0 or len(sources) == 0:
        return out, loose, matched
    span = float(np.nanmax(np.abs(np.concatenate([old.origin[:, 1], new.origin[:, 1]])), initial=0.0)) + 1.0
    curve_ids = np.unique(np.concatenate([old.origin[:, 0], new.origin[:, 0]]))

    def position(segments: Segments, index: np.ndarray) -> np.ndarray:  # curve (ranked: ids may be large), then place
        curve, place = np.searchsorted(curve_ids, segments.origin[index, 0]), np.nan_to_num(segments.origin[index, 1])
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
    return out, loose, matched


def solve_reference(segments: Segments) -> np.ndarray:
    """The unknowns ``(n, 3)`` of ``segments``' system by a dense solve (plain; for tests)."""
    matrix, rhs = assemble(segments)
    return np.linalg.solve(matrix, rhs)
