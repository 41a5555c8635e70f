"""Fast multipole boundary-element solve: GMRES whose product is the FMM.

The collocation system of ``dense`` is never formed.  Its product with a
vector of unknowns x (E on curves, C on the border) is the field of those
densities at every segment midpoint: far field through the same upward and
downward passes that build the representation, near field (the 3x3 block)
by exact integrals; border rows subtract x / 2.  The three colour channels
are one stacked vector, so every product is one three-channel FMM pass.

This first-kind (log kernel) system is ill-conditioned: a near-field
preconditioner only tames its high frequencies and leaves GMRES hundreds of
iterations (530 on poivron).  The preconditioner is therefore a compressed
factorisation of the whole matrix (``skeleton``, its columns scaled to the
segments' total flux), compressed to 1e-6 or 1e-5
(``compression_tolerance``): GMRES then needs 2 iterations on lady_bug, 3
on roses and 4 on pink_flowers; tighter compression costs more than the
iterations it saves (``bench/bench_solve.py``).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from ..fmm.far_field import far_field_at
from ..fmm.lattice import Lattice, cell_order, dilated, fine_multipoles
from ..fmm.sparse_downward import delta_local
from ..geometry.segments import Segments
from ..kernels.segment_sums import direct_sum, near_sum, pair_matrices
from .dense import SingularSystemError, assemble, check_dense_fits, dense_factors, trivial
from .near_matrix import NearMatrix
from .skeleton import SkeletonFactorization

#: Unknowns up to which the dense solve is faster (``bench/bench_solve.py``).
DENSE_CROSSOVER = 1500
#: Most unknowns solved densely (least squares) when the compressed factorisation finds the system singular.
DENSE_FALLBACK = 8000
#: Relative residual above which ``solve_boundary`` warns that GMRES did not converge.
UNCONVERGED = 1e-6
#: Relative residual above which the solve's answer is refused (``SingularSystemError``): its colours would be
#: visibly wrong, and a wrong picture is worse than a clear message.
UNUSABLE = 1e-3
#: Points at which ``check_colour_range`` tests a solve that stopped short of its tolerance.
RANGE_POINTS = 256
#: Relative residual the iterative solve aims at.
GMRES_RTOL = 1e-9
#: GMRES restarts after this many iterations (a cycle) ...
GMRES_RESTART = 30
#: ... and runs at most this many cycles,
GMRES_CYCLES = 10
#: stopping early when a cycle cut the true residual by less than this factor: where curves
#: nearly coincide the compressed factorisation can be too poor a preconditioner for GMRES to converge at
#: all (a poivron.xml with its control points on the canvas corners and edge midpoints crept for 300
#: iterations, 0.6 s each, and ended 3,000 times its right-hand side off).
STALLED_CYCLE = 4.0
#: Curve segments shorter than this fraction of the geometry's extent count as points (``solved_segments``).
POINT_LENGTH = 1e-12
#: Source-target pairs up to which a product with few sources (an eighth of the segments or fewer: a colour
#: edit of a curve) sums them directly: about 1 M pairs took what the FMM passes take on lady_bug's solve
#: lattice (10 ms; fruits 30 ms).  A product of most segments stays the FMM's, as GMRES's products are.
DIRECT_PAIRS = 1_000_000


def compression_tolerance(count: int) -> float:
    """Preconditioner accuracy for ``count`` unknowns (measured by ``bench/bench_solve.py``).

    Looser compression means cheaper factors but more GMRES products; on
    large, dense files (roses: 90k unknowns) 1e-5 was faster overall than
    1e-6 (51 s against 69 s, 16 against 9 iterations) and smaller.
    """
    return 1e-6 if count <= 30_000 else 1e-5


@dataclass(frozen=True)
class SolveReport:
    """How the iterative solve went."""

    iterations: int
    residual: float
    preconditioner: SkeletonFactorization


class CollocationOperator:
    """Products with the collocation matrix of sorted ``segments`` by FMM.

    Parameters
    ----------
    segments : Segments
        Sorted by fine cell of ``lattice``.
    cell_start : numpy.ndarray
        CSR offsets of each cell's segments.
    lattice : Lattice
    order : int
        Terms carried through the FMM passes.
    """

    def __init__(self, segments: Segments, cell_start: np.ndarray, lattice: Lattice, order: int) -> None:
        self.segments, self.cell_start, self.lattice, self.order = segments, cell_start, lattice, order
        self.cells = lattice.cell_of(segments.midpoints)
        self.border = segments.on_border[:, None]

    def field(self, flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
        """``sum_j E_j S_ij - C_j D_ij`` at every midpoint (own double layer 0), ``(n, 3)``.

        When few segments carry densities (a change of some curves' colours),
        their field is summed directly (``DIRECT_PAIRS``), or M2L runs from
        their cells only and the near field is summed only around them.
        """
        sources = np.flatnonzero(np.any(flux != 0, axis=1) | np.any(jump != 0, axis=1))
        if len(sources) * len(flux) <= DIRECT_PAIRS and 8 * len(sources) <= len(flux):
            return self._direct_field(sources, flux[sources], jump[sources])
        out, fine = self._far_field(flux, jump)
        seg, lattice = self.segments, self.lattice
        rows = np.flatnonzero(dilated(np.any(fine != 0, axis=(2, 3)))[self.cells[:, 0], self.cells[:, 1]])
        out[rows] += near_sum(
            seg.midpoints[rows], lattice.cells_per_side, lattice.cell_size, self.cell_start, seg.p, seg.q,
            np.ascontiguousarray(flux), np.ascontiguousarray(jump), own=rows,
        )
        return out

    def _far_field(self, flux: np.ndarray, jump: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The field at every midpoint of all but the 3x3 cells around it, and the fine cells' multipoles."""
        seg = replace(self.segments, flux=flux, jump=jump)
        fine = fine_multipoles(seg, self.cell_start, self.lattice, self.order)
        local = delta_local(fine, self.lattice, self.order)
        return far_field_at(local, self.lattice, self.cells, seg.midpoints), fine

    def _direct_field(self, sources: np.ndarray, flux: np.ndarray, jump: np.ndarray) -> np.ndarray:
        """``field`` of the ``sources`` with these densities, summed directly (the own double layer 0 on theirs)."""
        seg = self.segments
        p, q, midpoints = seg.p[sources], seg.q[sources], seg.midpoints
        out = direct_sum(midpoints, p, q, flux, jump)
        single, double = pair_matrices(midpoints[sources], p, q)
        np.fill_diagonal(double, 0.0)  # a target inside a segment gets one side there: the principal value instead
        out[sources] = single @ flux - double @ jump
        return out

    def apply(self, unknown: np.ndarray, near: NearMatrix | None = None) -> np.ndarray:
        """Collocation matrix times ``unknown (n, 3)``; ``near``, when given, is ``near_matrix()``'s."""
        flux = np.where(self.border, 0.0, unknown)
        jump = np.where(self.border, unknown, 0.0)
        field = self.field(flux, jump) if near is None else self._far_field(flux, jump)[0] + near @ unknown
        return field - np.where(self.border, 0.5 * unknown, 0.0)

    def near_matrix(self, curve_double: bool = False) -> NearMatrix | None:
        """The near part of the matrix, for ``apply`` (and with ``curve_double``, ``right_hand_side``) to reuse; None
        where it would exceed ``NEAR_MATRIX_BYTES``."""
        return NearMatrix.within_budget(self.segments, self.cell_start, self.lattice.cells_per_side, curve_double)

    def right_hand_side(self, jump: np.ndarray | None = None, mean: np.ndarray | None = None,
                        near: NearMatrix | None = None) -> np.ndarray:
        """``mean_i + sum over curves of D_ij C_j``, zero mean on the border rows.

        ``jump`` and ``mean`` (sorted like the segments) default to the segments' own; ``near``, when given,
        is ``near_matrix(curve_double=True)``'s.
        """
        jump = self.segments.jump if jump is None else jump
        mean = self.segments.mean if mean is None else mean
        curve_jump = np.where(self.border, 0.0, jump)
        no_flux = np.zeros_like(curve_jump)
        if near is None:
            field = self.field(no_flux, curve_jump)
        else:
            field = self._far_field(no_flux, curve_jump)[0] - near.double_layer(curve_jump)
        return np.where(self.border, 0.0, mean) - field


def solve_fmm(
    segments: Segments,
    cell_start: np.ndarray,
    lattice: Lattice,
    order: int = 20,
    rtol: float = GMRES_RTOL,
    tolerance: float | None = None,
    preconditioner: SkeletonFactorization | None = None,
    initial: np.ndarray | None = None,
    progress: Callable[[float], None] | None = None,
) -> tuple[Segments, SolveReport]:
    """Solve the collocation system by GMRES with FMM products.

    Parameters
    ----------
    segments : Segments
        Sorted by fine cell of ``lattice``.
    cell_start : numpy.ndarray
    lattice : Lattice
        Any lattice the segments are sorted for (a coarser one than the
        representation's makes each product cheaper).
    order : int
        Terms carried through the FMM passes of each product.
    rtol : float
        Relative residual (2-norm over all channels) to reach.
    tolerance : float, optional
        Compression accuracy of the preconditioner, when one is made; by
        default ``compression_tolerance(len(segments))``.
    preconditioner : SkeletonFactorization, optional
        A factorisation of the same matrix to reuse (a colour-only change).
    initial : numpy.ndarray, optional
        ``(n, 3)`` starting guess (a previous solution); by default the
        preconditioner's own solution.
    progress : callable, optional
        Called with the fraction of the work done.

    Returns
    -------
    segments : Segments
        With ``flux`` (curves) and ``jump`` (border) solved.
    report : SolveReport
    """
    report = progress or (lambda fraction: None)
    if preconditioner is None:
        tolerance = compression_tolerance(len(segments)) if tolerance is None else tolerance
        preconditioner = SkeletonFactorization(segments, tolerance, progress=lambda f: report(0.8 * f))
    operator = CollocationOperator(segments, cell_start, lattice, order)
    unknown, result = gmres(operator, operator.right_hand_side(), preconditioner, rtol, initial,
                            lambda f: report(0.8 + 0.2 * f))
    return segments.with_unknowns(unknown), result


def gmres(
    operator: CollocationOperator,
    rhs: np.ndarray,
    preconditioner: SkeletonFactorization,
    rtol: float = GMRES_RTOL,
    initial: np.ndarray | None = None,
    progress: Callable[[float], None] | None = None,
    near: NearMatrix | None = None,
) -> tuple[np.ndarray, SolveReport]:
    """Unknowns ``(n, 3)`` with ``operator.apply(x) = rhs`` to ``rtol``, by preconditioned GMRES.

    ``initial`` defaults to the preconditioner's own solution; ``progress``
    gets the fraction of the residual reduction reached; ``near``, the
    operator's ``near_matrix()`` when made already.  Restarts every
    ``GMRES_RESTART`` iterations, at most ``GMRES_CYCLES`` times, and stops
    after a cycle that cut the residual by less than ``STALLED_CYCLE``.
    """
    report = progress or (lambda fraction: None)
    n = len(rhs)
    if not np.any(rhs):
        return np.zeros_like(rhs), SolveReport(0, 0.0, preconditioner)
    last = {}
    if near is None:
        near = operator.near_matrix()  # about one product's near field to compute; every solve takes two or more

    def product(vector: np.ndarray) -> np.ndarray:
        if "x" in last and np.array_equal(vector, last["x"]):  # a cycle starts where the last one ended
            return last["ax"].copy()
        last["x"], last["ax"] = vector.copy(), operator.apply(vector.reshape(n, 3), near).ravel()
        return last["ax"]

    shape = (3 * n, 3 * n)
    matrix = scipy.sparse.linalg.LinearOperator(shape, product, dtype=float)
    inverse = scipy.sparse.linalg.LinearOperator(
        shape, lambda v: preconditioner.solve(v.reshape(n, 3)).ravel(), dtype=float
    )
    iterations = 0

    def step(residual_norm: float) -> None:
        nonlocal iterations
        iterations += 1
        report(min(1.0, np.log(max(residual_norm, 1e-300)) / np.log(rtol)))

    unknown = (preconditioner.solve(rhs) if initial is None else initial).ravel()
    before = np.linalg.norm(rhs.ravel() - product(unknown))  # GMRES's first product, kept for it
    for _ in range(GMRES_CYCLES):
        cycle_start = iterations
        unknown, converged = scipy.sparse.linalg.gmres(
            matrix, rhs.ravel(), x0=unknown, rtol=rtol, atol=0.0, restart=GMRES_RESTART, maxiter=1,
            M=inverse, callback=step, callback_type="pr_norm",
        )
        if converged == 0 or iterations == cycle_start:
            break
        after = np.linalg.norm(rhs.ravel() - last["ax"])  # every cycle ends on the product of its answer
        if before < STALLED_CYCLE * after:
            break  # this cycle barely cut the true residual: more would not either
        before = after
    # GMRES ends on a true residual; reuse that product unless it stopped elsewhere
    applied = last["ax"] if np.array_equal(last.get("x"), unknown) else product(unknown)
    residual = float(np.linalg.norm(applied - rhs.ravel()) / max(np.linalg.norm(rhs), 1e-300))
    report(1.0)
    return unknown.reshape(n, 3), SolveReport(iterations, residual, preconditioner)


class BoundarySolver:
    """The boundary system of one geometry, factorised once and solved for any colours.

    Up to ``DENSE_CROSSOVER`` unknowns the dense matrix is LU-factorised;
    above, the compressed factorisation preconditions GMRES with FMM
    products.  Right-hand sides come from FMM products either way, so a
    change of colours costs one product and one solve (``right_hand_side``
    of the change of colours, then ``solve``).

    Degenerate geometry: curve segments as short as a point take no part
    (``solved_segments``; their ``E`` is 0).  Where curves coincide the
    system is singular: the dense solve shares the density out by least
    squares, and so does the compressed one's fallback, up to
    ``DENSE_FALLBACK`` unknowns.

    Parameters
    ----------
    segments : Segments
        The geometry (end points, ``on_border``); their colours are not used.
    lattice : Lattice
        Lattice for the products (see ``solve_fmm``).
    progress : callable, optional
        Called with the fraction of the factorisation done.

    Raises
    ------
    SolveTooLargeError
        Early, when the system cannot fit in memory.
    SingularSystemError
        A ``ValueError``: the system is singular and too large for the dense fallback.
    """

    def __init__(self, segments: Segments, lattice: Lattice, progress: Callable[[float], None] | None = None) -> None:
        self.size = len(segments)
        taking_part = solved_segments(segments)
        self.taking_part = taking_part  # the others are too short to count (``solved_segments``)
        order, cell_start = cell_order(segments.take(taking_part), lattice)
        self.order = taking_part[order]
        ordered = segments.take(self.order)
        self.trivial = trivial(ordered)
        self.operator = CollocationOperator(ordered, cell_start, lattice, order=20)
        self.dense = len(ordered) <= DENSE_CROSSOVER
        self.factors = None
        self.least_squares = False  # True where the dense matrix is nearly singular (see dense_factors)
        if self.trivial:
            return
        if not self.dense:
            try:
                self.factors = SkeletonFactorization(ordered, compression_tolerance(len(ordered)), progress=progress)
                return
            except SingularSystemError:  # coinciding curves: the dense solve shares them out, if not too large
                if len(ordered) > DENSE_FALLBACK:
                    raise
                self.dense = True
        check_dense_fits(len(ordered))
        self.factors, self.least_squares = dense_factors(assemble(ordered)[0], lambda: assemble(ordered)[0])

    def right_hand_side(self, jump: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """The system's right-hand side ``(n, 3)`` for segment colours ``jump`` and ``mean`` (input order)."""
        operator = self.operator
        rhs = operator.right_hand_side(jump[self.order], mean[self.order])
        return self._unsorted(rhs)

    def accuracy(self, iterate: bool = True) -> float:
        """Relative accuracy of ``solve``'s unknowns (roughly: the dense solve's rounding, GMRES's
        tolerance, or the compression tolerance without iterations)."""
        if self.dense or self.trivial:
            return 1e-13
        return GMRES_RTOL if iterate else self.factors.tolerance

    def solve_colours(self, jump: np.ndarray, mean: np.ndarray,
                      progress: Callable[[float], None] | None = None) -> np.ndarray:
        """``solve(right_hand_side(jump, mean))``, the near entries computed once for both (a build's solve).

        A solve that stopped short of its tolerance is also refused (``SingularSystemError``) when the colours
        it gives leave the curves' range (``check_colour_range``): a residual below ``UNUSABLE`` does not rule
        that out where the system is nearly singular.
        """
        if self.trivial or self.dense:
            return self.solve(self.right_hand_side(jump, mean), progress)
        near = self.operator.near_matrix(curve_double=True)
        colours = jump[self.order], mean[self.order]
        rhs = self._unsorted(self.operator.right_hand_side(*colours, near))
        return self.solve(rhs, progress, near=near, colours=colours)

    def solve(self, rhs: np.ndarray, progress: Callable[[float], None] | None = None,
              iterate: bool = True, near: NearMatrix | None = None,
              colours: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """Unknowns ``(n, 3)`` (E on curves, C on the border, input order) for ``rhs`` (input order).

        With ``iterate=False`` the compressed factorisation's own solution is
        returned, without GMRES (its products are most of a solve's time):
        accurate to about the compression tolerance, which is plenty for the
        change of a few colours.  The dense solve is always exact.  ``near``:
        the operator's near matrix, when made already; ``colours``, the
        ``(jump, mean)`` of ``rhs`` (sorted), for ``check_colour_range``.
        """
        if self.trivial:
            return np.zeros((self.size, *rhs.shape[1:]))
        ordered = rhs[self.order]
        if self.dense:
            return self._unsorted(self.factors(ordered))
        if not iterate:
            return self._unsorted(self._finite(self.factors.solve(ordered)))
        unknown, report = gmres(self.operator, ordered, self.factors, progress=progress, near=near)
        if report.residual > UNUSABLE:
            raise SingularSystemError(
                f"{len(self.order):,} boundary segments: the solve does not converge (relative residual "
                f"{report.residual:.1e} after {report.iterations} iterations), as where curves nearly coincide or "
                "run close beside each other or the canvas edge")
        if report.residual > UNCONVERGED:
            if colours is not None:
                check_colour_range(self.operator.segments, unknown, *colours)
            warnings.warn(f"the boundary solve stopped at relative residual {report.residual:.1e} after "
                          f"{report.iterations} iterations; colours may be off", RuntimeWarning, stacklevel=2)
        return self._unsorted(self._finite(unknown))

    def _finite(self, unknown: np.ndarray) -> np.ndarray:
        """``unknown``, checked: the compressed factorisation of a nearly singular system may overflow."""
        if not np.isfinite(unknown).all():
            raise SingularSystemError(f"{len(self.order):,} boundary segments: their system is singular "
                                      "(curves coincide or nearly coincide); the iterative solve gave no finite answer")
        return unknown

    def _unsorted(self, values: np.ndarray) -> np.ndarray:
        return scattered(values, self.order, self.size)


def check_colour_range(segments: Segments, unknown: np.ndarray, jump: np.ndarray, mean: np.ndarray) -> None:
    """Refuse (``SingularSystemError``) solved densities whose colours leave the curves' range by a whole range.

    The colour field is harmonic away from the curves, with the canvas edge reflecting, so it stays within
    the range of the curves' side colours ``mean +- jump / 2`` (the maximum principle) but for the solve's
    small error.  ``RANGE_POINTS`` seeded points over the segments' box, summed directly, test it: a
    nearly singular system can leave a small residual at the collocation points and colours of 1e9-1e11
    between them (curves crowding the canvas edge: 36% of the pixels outside [0, 1] at a residual of 6.4e-4).
    """
    curve = ~segments.on_border
    if not curve.any():
        return
    sides = np.concatenate([mean[curve] - 0.5 * np.abs(jump[curve]), mean[curve] + 0.5 * np.abs(jump[curve])])
    low, high = sides.min(axis=0), sides.max(axis=0)
    margin = max(float((high - low).max()), 1.0 / 255)
    ends = np.concatenate([segments.p, segments.q])
    points = np.random.default_rng(0).uniform(ends.min(axis=0), ends.max(axis=0), (RANGE_POINTS, 2))
    solved = replace(segments, jump=jump).with_unknowns(unknown)
    values = direct_sum(points, solved.p, solved.q, solved.flux, solved.jump)
    beyond = float(np.max(np.maximum(low - values, values - high), initial=0.0))
    if not beyond <= margin:
        raise SingularSystemError(
            f"{len(segments):,} boundary segments: the solve does not converge (its colours reach {beyond:.3g} "
            "beyond the curves' own), as where curves nearly coincide or run close beside each other or the canvas "
            "edge")


def solved_segments(segments: Segments) -> np.ndarray:
    """Indices of the segments the system solves for: the border and every curve segment longer than a point.

    A curve segment shorter than ``POINT_LENGTH`` times the extent of the
    geometry (zero-length ones above all) has no field of its own worth the
    name (``S`` and ``D`` vanish with its length) and its own equation would
    make the system singular or overflow its density: it keeps ``E = 0``.
    """
    lengths = segments.lengths
    if len(lengths) == 0:
        return np.zeros(0, np.int64)
    return np.flatnonzero(segments.on_border | (lengths > POINT_LENGTH * extent_of(segments)))


def extent_of(segments: Segments) -> float:
    """The longer side of the box around ``segments`` (at least 1), which ``solved_segments`` measures against."""
    return max(float(np.ptp(np.concatenate([segments.p, segments.q]), axis=0).max()), 1.0)


def scattered(values: np.ndarray, order: np.ndarray, size: int) -> np.ndarray:
    """``values`` of the segments ``order`` (the ones taking part, in cell order) in input order, 0 on the others."""
    out = np.zeros((size, *values.shape[1:]))
    out[order] = values
    return out


def solve_boundary(
    segments: Segments, lattice: Lattice, progress: Callable[[float], None] | None = None
) -> Segments:
    """Solve the boundary system densely or iteratively, whichever is faster for its size.

    Parameters
    ----------
    segments : Segments
    lattice : Lattice
        Lattice for the iterative solve's products.
    progress : callable, optional
        Called with the fraction of the work done.

    Raises
    ------
    SolveTooLargeError
        Early, when the system cannot fit in memory.
    """
    report = progress or (lambda fraction: None)
    solver = BoundarySolver(segments, lattice, lambda f: report(0.8 * f))
    return segments.with_unknowns(solver.solve_colours(segments.jump, segments.mean, lambda f: report(0.8 + 0.2 * f)))
