"""A drag's previews: the densities of a nearby geometry without solving the whole boundary system.

Every preview of a drag starts from the same exact state, the *base* (its
segments and solved unknowns), so that nothing drifts along the drag:

1. **Carry.**  Kept segments keep their unknowns; moved or new ones take
   those of the nearest base segment of the same curve (``updated``'s
   ``carried_unknowns``).  Alone, that is wrong twice over: the moved
   segments' lengths change the curves' net flux ``sum E h``, which is 0 in
   the exact solution (no colour leaves a reflecting canvas), and a net flux
   is a source whose logarithmic field moves the level of the whole picture
   (lady_bug, an anchor moved 6 px: 1.3/255 everywhere); and a curve close
   to others needs other densities once the gap between them changes (a
   highlight moved 5 px: 4/255 mean, 22/255 at the 99th percentile).
2. **Solve near the change.**  The moved segments and the ``NEARBY``
   segments nearest to them are solved for again, the rest held.  The
   carried unknowns' residual on those rows is known without a product over
   the whole system: the base is exact, so on a kept segment it is the field
   of the removed segments minus that of the added ones, and on a moved one
   its colours minus the base's field there (``field``, from its
   representation), again with the removed segments' field taken out and
   the added ones' put in.  The local system is bordered by the net flux
   kept and one unknown constant, the level the rest of the picture lends
   the region (as the clone's seam is, docs/design.md section 6).
3. **Say how good it is.**  The preview's residual at ``SAMPLES`` kept
   collocation points (the field of what changed, summed directly) is the
   error of its picture on the curves there: the error is continuous across
   the curves (both carry the same colour jumps) and harmonic between them,
   so the picture's error follows its values on the curves.  Measured on
   lady_bug's drags, the samples' mean and 99th percentile came within a
   third of the picture's.  ``Preview.trusted`` holds them to the bound the
   screen promises (1/255 mean, 4/255 at the 99th percentile) with a margin.
4. **Let the rest answer, where the bound is missed.**  Up to ``SWEEPS``
   times, the held rows' residual is solved for through the base's
   factorisation (the kept block's inverse, a Schur complement of it; a
   curve moved towards another needs the whole system's answer), then the
   rows near the change again.  Only for documents up to
   ``GLOBAL_STEP_SEGMENTS``, where that fits in a frame; a preview still
   beyond the bound is not shown (``LiveRepresentation`` shows the last
   exact picture instead).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.spatial import cKDTree

from ..geometry.segments import Segments
from ..kernels.segment_sums import direct_sum, pair_matrices
from .entries import CollocationEntries
from .solver import POINT_LENGTH, extent_of, solved_segments
from .updated import carried_unknowns_and_loose

#: Segments solved for again around the moved ones (besides those): a dense system of about this size.
NEARBY = 300
#: Kept collocation points the residual is sampled at.
SAMPLES = 2000
#: Most boundary segments for which a preview may ask the base's factorisation (step 4 of the module): on
#: lady_bug (7,291 segments) that is the removed segments' columns once a drag (some 60 base solves, about
#: 70 ms) and then, each frame, a base solve (6 ms) and the change of every cell's expansions (about 20 ms).
GLOBAL_STEP_SEGMENTS = 15_000
#: Rounds of the held rows' answer and the local solve after it, at most (step 4 of the module).
SWEEPS = 2
#: Largest estimated error (colour units, from the residual's samples) of a preview that is shown: the
#: screen's bound (1/255 mean, 4/255 at the 99th percentile) over a margin of 1.5 for the estimate.
TRUSTED_MEAN, TRUSTED_P99 = 1 / 255 / 1.5, 4 / 255 / 1.5

Field = Callable[[np.ndarray], np.ndarray]
Solve = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Preview:
    """A preview's unknowns and its estimated error.

    Attributes
    ----------
    unknowns : numpy.ndarray
        ``(n, 3)``, as the boundary system's.
    mean, p99 : float
        Mean and 99th percentile over the sampled collocation points of the
        residual (largest channel): the picture's error there.
    global_step : bool
        True when the rest of the system answered too (every density changed).
    """

    unknowns: np.ndarray
    mean: float = 0.0
    p99: float = 0.0
    global_step: bool = False

    @property
    def trusted(self) -> bool:
        """True when the estimated error is within what the screen may show."""
        return self.mean <= TRUSTED_MEAN and self.p99 <= TRUSTED_P99


class Previews:
    """Previews of geometries near one exact state (a drag's start).

    Parameters
    ----------
    base : Segments
        The exact state's boundary segments.
    unknowns : numpy.ndarray
        Their solved unknowns ``(n, 3)`` (E on curves, C on the border).
    field : callable
        ``field(points (m, 2)) -> (m, 3)``: the base's field at points off
        its segments (its representation's curves, no diffusion points).
    solve : callable, optional
        ``solve(rhs (n, 3)) -> (n, 3)``: the base system's solve (its
        factorisation), for a preview the local solve alone leaves beyond
        the bound; None where that costs more than a frame may.
    nearby : int
        Segments solved for again around the moved ones.
    """

    def __init__(self, base: Segments, unknowns: np.ndarray, field: Field, solve: Solve | None = None,
                 nearby: int = NEARBY) -> None:
        self.base, self.base_unknowns, self.field, self.solve, self.nearby = base, unknowns, field, solve, nearby
        self._tree: cKDTree | None = None  # of the base's midpoints, made by the first preview that needs it
        self._columns: dict[int, np.ndarray] = {}  # the base's inverse applied to unit vectors, by segment
        self._taking = np.zeros(len(base), bool)
        self._taking[solved_segments(base)] = True
        self._flux = _net_flux(base, unknowns)
        self._extent = extent_of(base)  # a new geometry's too: the border spans the canvas, curves are clipped to it
        rng = np.random.default_rng(0)  # the same samples every time: a deterministic decision
        self._samples = np.sort(rng.choice(len(base), min(SAMPLES, len(base)), replace=False))

    def preview(self, new: Segments) -> Preview:
        """The preview of the geometry ``new``."""
        base, known = self.base, self.base_unknowns
        carried, loose, (kept_base, kept) = carried_unknowns_and_loose(base, known, new)
        taking = np.zeros(len(new), bool)  # kept segments take part as they did; of the loose, those not a point
        taking[kept] = self._taking[kept_base]
        taking[new.on_border] = True
        taking[loose] = new.lengths[loose] > POINT_LENGTH * self._extent
        moved = loose[taking[loose]]
        if len(moved) == 0:
            return Preview(carried)
        in_new = np.full(len(base), -1, np.int64)
        in_new[kept_base] = kept
        removed = np.flatnonzero(in_new < 0)
        near = self._near(new, moved, in_new, taking)
        rows = np.concatenate([near, moved])
        solved = np.zeros(len(new), bool)
        solved[rows] = True
        samples = in_new[self._samples]
        samples = samples[samples >= 0]
        held, held_samples = kept[~solved[kept]], samples[~solved[samples]]
        gone = _Sources.of(base.take(removed), known[removed])

        # 1. the moved segments and those near them solved again, the rest held; on a moved row the residual
        # starts as its colours minus the base's field there, on a kept row as nothing (the base is exact)
        local = _LocalSystem(new.take(rows))
        residual = _Sources.join(gone, _Sources.of(new.take(loose), carried[loose], -1.0, ids=loose)).at(
            new.midpoints[rows], rows)
        residual[len(near):] += new.mean[moved] - self.field(new.midpoints[moved])
        unknowns = carried
        excess = _net_flux(new.take(loose), unknowns[loose]) - _net_flux(base.take(removed), known[removed])
        delta, level = local.solve(residual, excess)  # excess: the change of the curves' net flux
        unknowns[rows] += delta
        # the residual elsewhere: the field of all that changed (on the rows solved: their level)
        missed = _Sources.join(gone, _Sources.of(new.take(loose), unknowns[loose], -1.0),
                               _Sources.of(new.take(near), delta[: len(near)], -1.0, colours=False))
        estimate = Preview(unknowns, *_spread(missed.at(new.midpoints[held_samples]), level, samples, held_samples))
        if estimate.trusted or self.solve is None:
            unknowns[~taking] = 0.0
            return estimate
        # 2. and 3., up to ``SWEEPS`` times: the held rows answer exactly (the kept block's own solve, through
        # the base's factorisation), then the rows near the change again
        try:
            kept_solve = self._kept_solve(removed[self._taking[removed]], kept_base)
        except np.linalg.LinAlgError:  # the base's update is singular: no answer to take
            unknowns[~taking] = 0.0
            return estimate
        residual = np.zeros((len(new), 3))
        residual[held] = missed.at(new.midpoints[held])
        for _ in range(SWEEPS):
            residual[rows] = level
            answer = kept_solve(residual[kept])
            unknowns[kept] += answer
            # the kept rows are satisfied now; a moved row misses the kept segments' answer
            again = np.zeros((len(rows), 3))
            again[len(near):] = level - _Sources.of(new.take(kept), answer, colours=False).at(new.midpoints[moved])
            delta, level = local.solve(again, _net_flux(new, unknowns) - self._flux)
            unknowns[rows] += delta
            changed = _Sources.of(new.take(rows), delta, -1.0, colours=False)
            residual[held] = changed.at(new.midpoints[held])
            estimate = Preview(unknowns, *_spread(changed.at(new.midpoints[held_samples]), level, samples,
                                                  held_samples), global_step=True)
            if estimate.trusted:
                break
        unknowns[~taking] = 0.0
        return estimate

    def _kept_solve(self, removed: np.ndarray, kept_base: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """``values -> A_KK^-1 values`` for the base system's kept block (rows and columns ``kept_base``).

        With ``G`` the base's inverse and ``R`` the ``removed`` segments taking
        part, ``A_KK^-1 v = (G [v; 0])_K - G_KR G_RR^-1 (G [v; 0])_R`` (as in
        ``updated``).  ``G``'s columns of ``R`` are solved for once a drag
        (they are kept by segment), the rest is one base solve.

        Raises
        ------
        numpy.linalg.LinAlgError
            When ``G_RR`` is singular.
        """
        n, columns = len(self.base), self._columns
        missing = [r for r in removed.tolist() if r not in columns]
        if missing:
            units = np.zeros((n, len(missing)))
            units[missing, np.arange(len(missing))] = 1.0
            columns.update(zip(missing, self.solve(units).T))
        g_r = np.column_stack([columns[r] for r in removed.tolist()]) if len(removed) else np.zeros((n, 0))
        g_rr = scipy.linalg.lu_factor(g_r[removed], check_finite=False) if len(removed) else None

        def kept_solve(values: np.ndarray) -> np.ndarray:
            embedded = np.zeros((n, values.shape[1]))
            embedded[kept_base] = values
            solved = self.solve(embedded)
            if g_rr is not None:
                solved -= g_r @ scipy.linalg.lu_solve(g_rr, solved[removed], check_finite=False)
            return solved[kept_base]

        return kept_solve

    def _near(self, new: Segments, moved: np.ndarray, in_new: np.ndarray, taking: np.ndarray) -> np.ndarray:
        """Indices into ``new`` of about ``nearby`` kept segments taking part nearest to the ``moved`` ones.

        Each moved segment's nearest base segments are looked up, so many that
        all of them together hold the ``nearby`` nearest to the moved set.
        """
        if self._tree is None:
            self._tree = cKDTree(self.base.midpoints)
        each = min(len(self.base), 2 * len(moved) + self.nearby // len(moved) + 1)
        distance, index = self._tree.query(new.midpoints[moved], k=each)
        candidate, distance = in_new[index.ravel()], distance.ravel()
        usable = candidate >= 0
        usable[usable] = taking[candidate[usable]]
        candidate, distance = candidate[usable], distance[usable]
        nearest = np.full(len(new), np.inf)
        np.minimum.at(nearest, candidate, distance)
        found = np.flatnonzero(np.isfinite(nearest))
        return np.sort(found[np.argsort(nearest[found], kind="stable")[: self.nearby]])


@dataclass(frozen=True)
class _Sources:
    """Segments with densities, their field summed directly: ``sum E S - C D``.

    ``ids`` are their indices in the new geometry (-1: none): a point given
    as a segment's midpoint takes that segment's double layer as 0 there
    (the principal value).
    """

    p: np.ndarray
    q: np.ndarray
    flux: np.ndarray
    jump: np.ndarray
    ids: np.ndarray

    @classmethod
    def of(cls, segments: Segments, values: np.ndarray, sign: float = 1.0, colours: bool = True,
           ids: np.ndarray | None = None) -> _Sources:
        """``segments`` with unknowns ``values`` (E on curves, C on the border) times ``sign``, and with their
        colour jumps too unless ``colours`` is false (a change of densities only)."""
        border = segments.on_border[:, None]
        flux = np.where(border, 0.0, values)
        jump = np.where(border, values, segments.jump if colours else 0.0)
        ids = np.full(len(segments), -1, np.int64) if ids is None else np.asarray(ids, np.int64)
        return cls(segments.p, segments.q, sign * flux, sign * jump, ids)

    @classmethod
    def join(cls, *parts: _Sources) -> _Sources:
        return cls(*(np.concatenate([getattr(part, name) for part in parts]) for name in ("p", "q", "flux", "jump",
                                                                                          "ids")))

    def at(self, points: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """The field at ``points`` ``(m, 3)``; ``ids``: the segment (in the new geometry) each is the midpoint of."""
        if ids is None:
            return direct_sum(points, self.p, self.q, self.flux, self.jump)
        single, double = pair_matrices(points, self.p, self.q)
        order = np.argsort(self.ids, kind="stable")
        at = np.clip(np.searchsorted(self.ids[order], ids), 0, max(len(order) - 1, 0))
        own = np.flatnonzero((ids >= 0) & (self.ids[order][at] == ids)) if len(order) else np.zeros(0, np.int64)
        double[own, order[at[own]]] = 0.0
        return single @ self.flux - double @ self.jump


def _spread(held: np.ndarray, level: np.ndarray, samples: np.ndarray, held_samples: np.ndarray) -> tuple[float, float]:
    """Mean and 99th percentile over ``samples`` of the residual's largest channel: ``held`` at ``held_samples``,
    ``level`` at the others (rows solved again)."""
    size = np.concatenate([np.abs(held).max(axis=1, initial=0.0),
                           np.full(len(samples) - len(held_samples), np.abs(level).max())])
    return (float(size.mean()), float(np.percentile(size, 99))) if len(size) else (0.0, 0.0)


def _net_flux(segments: Segments, unknowns: np.ndarray) -> np.ndarray:
    """``sum E h`` over the curve segments, per channel."""
    curve = ~segments.on_border
    return segments.lengths[curve] @ unknowns[curve]


class _LocalSystem:
    """The new system on some of its rows and columns, bordered by the net flux and one constant level:
    ``[[A, 1], [h, 0]] [x; c] = [residual; -excess]``, factorised once for the solves of a preview.

    The border row and column are scaled to the matrix's own size (a
    well-scaled pivot); ``h`` is 0 on border segments, whose unknown is C.
    """

    def __init__(self, segments: Segments) -> None:
        n = len(segments)
        entries = CollocationEntries(segments).block(np.arange(n), np.arange(n))
        scale = float(np.abs(entries).max(initial=1.0))
        lengths = np.where(segments.on_border, 0.0, segments.lengths)
        self._scale, self._unit = scale, scale / max(float(lengths.max(initial=0.0)), 1e-300)
        matrix = np.block([[entries, np.full((n, 1), scale)], [self._unit * lengths[None, :], np.zeros((1, 1))]])
        self._factors = scipy.linalg.lu_factor(matrix, overwrite_a=True, check_finite=False)

    def solve(self, residual: np.ndarray, excess: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The change of the unknowns that zeroes ``residual`` up to a level and takes ``excess`` off the net flux,
        and that level ``(3,)``: the residual left on every row."""
        rhs = np.vstack([residual, -self._unit * excess[None, :]])
        solution = scipy.linalg.lu_solve(self._factors, rhs, check_finite=False)
        return solution[:-1], self._scale * solution[-1]
