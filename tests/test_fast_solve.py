"""The FMM product of the collocation system and the preconditioned GMRES against the dense solve."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.engine import build, rasterise
from fmr_editor.engine.fmm.far_field import far_field_at, far_field_at_reference
from fmr_editor.engine.fmm.lattice import Lattice, downward_pass, sort_into_cells, upward_pass
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
from fmr_editor.engine.kernels.segment_sums import near_sum, pair_matrices
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.engine.solve.dense import assemble, solve_dense
from fmr_editor.engine.solve.skeleton import SkeletonFactorization
from fmr_editor.engine.solve.solver import CollocationOperator, solve_fmm


@pytest.fixture(scope="module")
def system():
    doc = scattered_document()
    lattice = Lattice(4, 128.0)
    segments, cell_start = sort_into_cells(
        boundary_segments(curve_segments(doc, max_length=4.0), doc, lattice.cell_size, border_spacing=4.0), lattice
    )
    return segments, cell_start, lattice, *assemble(segments)


def test_fmm_product_equals_the_dense_matrix_product(system):
    segments, cell_start, lattice, matrix, _ = system
    unknown = np.random.default_rng(3).normal(size=(len(segments), 3))
    got = CollocationOperator(segments, cell_start, lattice, 20).apply(unknown)
    expected = matrix @ unknown
    assert np.abs(got - expected).max() <= 1e-8 * np.abs(expected).max()


def near_pairs(segments, lattice):
    """Whether each source lies in the 3x3 cells around each target's cell (plain: every pair)."""
    cells = lattice.cell_of(segments.midpoints)
    return np.abs(cells[:, None, :] - cells[None, :, :]).max(axis=2) <= 1


def test_the_kept_near_matrix_is_the_dense_matrix_on_neighbouring_cells(system):
    """Its product is the dense matrix's over the 3x3 cells around each midpoint (without the border's -1/2), and
    ``apply`` with it is the dense product, as without it."""
    segments, cell_start, lattice, matrix, _ = system
    unknown = np.random.default_rng(5).normal(size=(len(segments), 3))
    operator = CollocationOperator(segments, cell_start, lattice, 20)
    near = operator.near_matrix()
    own_border = np.diag(np.where(segments.on_border, -0.5, 0.0))
    expected = np.where(near_pairs(segments, lattice), matrix - own_border, 0.0) @ unknown
    np.testing.assert_allclose(near @ unknown, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    got = operator.apply(unknown, near)
    assert np.abs(got - matrix @ unknown).max() <= 1e-8 * np.abs(matrix @ unknown).max()
    np.testing.assert_allclose(got, operator.apply(unknown), rtol=0, atol=1e-12 * np.abs(got).max())
    _, double = pair_matrices(segments.midpoints, segments.p, segments.q)
    np.fill_diagonal(double, 0.0)  # the principal value
    expected = np.where(near_pairs(segments, lattice) & ~segments.on_border, double, 0.0) @ unknown
    kept = operator.near_matrix(curve_double=True)
    np.testing.assert_array_equal(kept @ unknown, near @ unknown)
    np.testing.assert_allclose(kept.double_layer(unknown), expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    with pytest.raises(ValueError, match="double layer"):
        near.double_layer(unknown)


@pytest.mark.parametrize("fits", [True, False], ids=["kept", "too large"])
def test_gmres_computes_the_near_entries_once(system, monkeypatch, fits):
    """GMRES computes the near entries once and reuses them in every product (no ``near_sum``); a system whose
    entries would exceed ``NEAR_MATRIX_BYTES`` sums them afresh in each product."""
    from fmr_editor.engine.solve import near_matrix

    segments, cell_start, lattice, _, _ = system
    operator = CollocationOperator(segments, cell_start, lattice, 20)
    rhs, preconditioner = operator.right_hand_side(), compressed(segments, 1e-3)
    if not fits:
        monkeypatch.setattr(near_matrix, "NEAR_MATRIX_BYTES", 0)
    sums, made, products = [], [], []
    monkeypatch.setattr(fast_solve, "near_sum", lambda *a, **k: sums.append(1) or near_sum(*a, **k))
    entries = near_matrix._entries
    monkeypatch.setattr(near_matrix, "_entries", lambda *a: made.append(1) or entries(*a))
    apply = CollocationOperator.apply
    monkeypatch.setattr(CollocationOperator, "apply", lambda *a: products.append(1) or apply(*a))
    unknown, report = fast_solve.gmres(operator, rhs, preconditioner, rtol=1e-11)
    assert report.iterations >= 2 and report.residual <= 1e-11 and len(products) > report.iterations
    assert (len(made), len(sums)) == ((1, 0) if fits else (0, len(products)))
    expected = solve_dense(segments).unknowns()
    assert np.abs(unknown - expected).max() <= 1e-6 * np.abs(expected).max()


def test_compiled_far_field_equals_the_numpy_reference(system):
    segments, cell_start, lattice, _, _ = system
    rng = np.random.default_rng(4)
    seg = replace(segments, flux=rng.normal(size=(len(segments), 3)), jump=rng.normal(size=(len(segments), 3)))
    local = downward_pass(upward_pass(seg, cell_start, lattice, 12), lattice, 12)
    points = rng.uniform(0, 128, (500, 2))
    cells = lattice.cell_of(points)
    expected = far_field_at_reference(local, lattice, cells, points)
    np.testing.assert_allclose(far_field_at(local, lattice, cells, points), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("kept", [False, True], ids=["summed", "from the kept near matrix"])
def test_fmm_right_hand_side_equals_the_dense_one(system, kept):
    segments, cell_start, lattice, _, rhs = system
    operator = CollocationOperator(segments, cell_start, lattice, 20)
    got = operator.right_hand_side(near=operator.near_matrix(curve_double=True) if kept else None)
    assert np.abs(got - rhs).max() <= 1e-8 * np.abs(rhs).max()


def test_a_builds_solve_computes_the_near_entries_once_for_its_right_hand_side_and_products(system, monkeypatch):
    """``solve_colours``: no near field summed afresh, one computation of the entries (with the double layer), and
    the unknowns of the right-hand side and solve made apart."""
    from fmr_editor.engine.solve import near_matrix

    segments, cell_start, lattice, _, _ = system
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 0)  # the compressed factorisation and GMRES
    solver = fast_solve.BoundarySolver(segments, lattice)
    expected = solver.solve(solver.right_hand_side(segments.jump, segments.mean))
    sums, made = [], []
    monkeypatch.setattr(fast_solve, "near_sum", lambda *a, **k: sums.append(1) or near_sum(*a, **k))
    entries = near_matrix._entries
    monkeypatch.setattr(near_matrix, "_entries", lambda *a: made.append(len(a[-1])) or entries(*a))
    got = solver.solve_colours(segments.jump, segments.mean)
    assert not sums and len(made) == 1 and made[0] > 0
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("direct", [True, False], ids=["summed directly", "fmm"])
def test_a_product_of_few_sources_equals_the_dense_matrix_product(system, direct, monkeypatch):
    """A colour edit's right-hand side: one curve's jumps (and some border unknowns) carry densities."""
    segments, cell_start, lattice, matrix, _ = system
    monkeypatch.setattr(fast_solve, "DIRECT_PAIRS", 10**9 if direct else 0)
    rng = np.random.default_rng(8)
    unknown = np.zeros((len(segments), 3))
    few = rng.choice(len(segments), 30, replace=False)
    unknown[few] = rng.normal(size=(30, 3))
    got = CollocationOperator(segments, cell_start, lattice, 20).apply(unknown)
    expected = matrix @ unknown
    assert np.abs(got - expected).max() <= (1e-12 if direct else 1e-8) * np.abs(expected).max()


def compressed(segments, tolerance):
    """A factorisation small boxes and a small top make compress through several levels."""
    return SkeletonFactorization(segments, tolerance, leaf_size=16, top_size=40)


def test_iterative_solve_matches_the_dense_solve(system):
    segments, cell_start, lattice, _, _ = system
    solved, report = solve_fmm(segments, cell_start, lattice, rtol=1e-11, preconditioner=compressed(segments, 1e-10))
    expected = solve_dense(segments).unknowns()
    assert report.residual <= 1e-11
    assert np.abs(solved.unknowns() - expected).max() <= 1e-6 * np.abs(expected).max()


def test_a_weak_preconditioner_still_converges_by_iterating(system):
    segments, cell_start, lattice, _, _ = system
    solved, report = solve_fmm(segments, cell_start, lattice, rtol=1e-11, preconditioner=compressed(segments, 1e-3))
    expected = solve_dense(segments).unknowns()
    assert report.iterations >= 2 and report.residual <= 1e-11
    assert np.abs(solved.unknowns() - expected).max() <= 1e-6 * np.abs(expected).max()


def test_a_reused_preconditioner_and_warm_start_need_no_new_factorisation(system):
    segments, cell_start, lattice, _, _ = system
    first, report = solve_fmm(segments, cell_start, lattice, preconditioner=compressed(segments, 1e-10))
    again, second = solve_fmm(segments, cell_start, lattice, preconditioner=report.preconditioner,
                              initial=first.unknowns())
    assert second.preconditioner is report.preconditioner
    assert second.iterations == 0
    np.testing.assert_array_equal(again.unknowns(), first.unknowns())


def test_build_above_the_crossover_gives_the_dense_image(monkeypatch):
    doc = scattered_document(96, circles=3, seed=5)
    dense = rasterise(build(doc), 48, 48, samples=1)
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 10)
    monkeypatch.setattr(fast_solve, "dense_factors", lambda *args: pytest.fail("dense solve used above the crossover"))
    fast = rasterise(build(doc), 48, 48, samples=1)
    assert np.abs(fast - dense).max() <= 1e-6


def one_iteration_with(factors, monkeypatch):
    """Every build's compressed solve through ``factors``, GMRES cut to a single iteration."""
    monkeypatch.setattr(fast_solve, "SkeletonFactorization", lambda *args, **kwargs: factors)
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 10)
    monkeypatch.setattr(fast_solve, "GMRES_CYCLES", 1)
    monkeypatch.setattr(fast_solve, "GMRES_RESTART", 1)


def test_a_solve_short_of_its_tolerance_says_so(system, monkeypatch):
    segments, _, lattice, _, _ = system
    one_iteration_with(compressed(segments, 1e-4), monkeypatch)  # a relative residual of 1.5e-5 left
    with pytest.warns(RuntimeWarning, match="stopped at relative residual"):
        fast_solve.solve_boundary(segments, lattice)


def test_densities_whose_colours_leave_the_curves_range_are_refused(system):
    """The maximum principle: the dense solution's colours stay within the curves' side colours (at the
    ``RANGE_POINTS`` points, within the check's margin), and densities blown up between the collocation points
    (an alternating 1e4 on the curve segments) are refused."""
    segments = system[0]
    solved = solve_dense(segments).unknowns()
    fast_solve.check_colour_range(segments, solved, segments.jump, segments.mean)
    curve = ~segments.on_border
    blown = solved + np.where(curve, 1e4 * (-1.0) ** np.arange(len(solved)), 0.0)[:, None]
    with pytest.raises(fast_solve.SingularSystemError, match="beyond the curves' own"):
        fast_solve.check_colour_range(segments, blown, segments.jump, segments.mean)


def test_a_solve_far_from_converging_is_refused_not_shown(system, monkeypatch):
    segments, _, lattice, _, _ = system
    one_iteration_with(compressed(segments, 0.5), monkeypatch)
    with pytest.raises(fast_solve.SingularSystemError, match="does not converge"):
        fast_solve.solve_boundary(segments, lattice)


class Blind:
    """A preconditioner that drops half the unknowns: GMRES cannot get past the part it never sees."""

    def __init__(self, size: int) -> None:
        self.seen = np.arange(size) % 2 == 0

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return np.where(self.seen[:, None], rhs, 0.0)


def test_gmres_stops_after_a_cycle_that_barely_cut_the_residual(system):
    segments, cell_start, lattice, matrix, rhs = system
    operator = CollocationOperator(segments, cell_start, lattice, 20)
    products = []
    counted = fast_solve.CollocationOperator.apply

    class Counting(CollocationOperator):
        def apply(self, values, near=None):
            products.append(1)
            return counted(self, values, near)

    operator.__class__ = Counting
    _, report = fast_solve.gmres(operator, rhs, Blind(len(segments)))
    assert report.residual > fast_solve.UNUSABLE
    # the first cycle cuts the residual of the preconditioner's own answer, the second barely: 2 of 10 cycles
    assert report.iterations == 2 * fast_solve.GMRES_RESTART
    assert len(products) == 2 * (fast_solve.GMRES_RESTART + 1) + 1  # a product per iteration, cycle end, start