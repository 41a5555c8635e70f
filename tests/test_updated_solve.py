"""Geometry edits solved through the factorisation of the geometry before them (engine/updated_solve.py)."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.engine.fmm.lattice import Lattice
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
from fmr_editor.engine.representation import choose_levels
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.engine.solve.dense import assemble
from fmr_editor.engine.solve.solver import BoundarySolver
from fmr_editor.engine.solve.updated import (
    UpdatedSolver,
    carried_unknowns,
    match_segments,
    match_segments_reference,
    solve_reference,
    updated_solver,
)
from fmr_editor.model import edits

SIDE = 96


def boundary(document):
    curves = curve_segments(document)
    return boundary_segments(curves, document, SIDE / 2**choose_levels(curves, SIDE), 1.0)


def solver_for(segments, dense: bool, monkeypatch) -> BoundarySolver:
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 10**6 if dense else 0)
    return BoundarySolver(segments, Lattice(3, float(SIDE)))


@pytest.fixture
def geometries():
    """A document and three edits of its geometry: an anchor moved, a curve deleted, a curve added."""
    document = scattered_document(SIDE, circles=3, seed=11)
    moved = edits.move_control_point(document, document.curves[1].id, 3,
                                     tuple(document.curves[1].control_points[3] + (3.0, -2.0)))
    deleted = edits.remove_curves(moved, [moved.curves[0].id])
    added = edits.add_curve(document, scattered_document(SIDE, circles=1, seed=12).curves[0])
    return [boundary(d) for d in (document, moved, deleted, added)]


def as_pairs(matched) -> set:
    return set(zip(*(values.tolist() for values in matched)))


def test_matching_by_head_and_tail_equals_matching_by_sorting(geometries):
    base = geometries[0]
    for new in geometries:
        old_index, new_index = match_segments(base, new)
        assert as_pairs((old_index, new_index)) == as_pairs(match_segments_reference(base, new))
        np.testing.assert_array_equal(base.p[old_index], new.p[new_index])
        assert len(set(old_index.tolist())) == len(old_index) and len(set(new_index.tolist())) == len(new_index)
    same = match_segments(base, base)
    assert all(np.array_equal(values, np.arange(len(base))) for values in same)
    twice = base.take(np.r_[np.arange(len(base)), 0])  # a duplicate matches once
    assert len(match_segments(base, twice)[0]) == len(base)


@pytest.mark.parametrize("dense", [True, False])
def test_the_updated_system_gives_the_new_systems_solution(geometries, dense, monkeypatch):
    base = geometries[0]
    solver = solver_for(base, dense, monkeypatch)
    columns = {}
    for new in geometries[1:]:
        updated = updated_solver(solver, base, new, solver.operator.lattice, columns)
        assert isinstance(updated, UpdatedSolver) and len(updated.added) > 0
        reference = solve_reference(new)
        scale = np.abs(reference).max()
        direct = updated.solve(_rhs(new))
        if dense:  # exact: the Schur complement of exact factors
            assert np.abs(direct - reference).max() <= 1e-8 * scale
        start = carried_unknowns(base, solver.solve(solver.right_hand_side(base.jump, base.mean)), new)
        corrected = updated.correct(start, new.jump, new.mean)
        assert np.abs(corrected - reference).max() <= 1e-6 * scale  # the FMM products' own accuracy
        assert np.abs(start - reference).max() > 1e3 * np.abs(corrected - reference).max()
    assert columns  # the removed segments' columns are kept for the next update


def _rhs(segments) -> np.ndarray:
    return assemble(segments)[1]


def test_the_old_densities_carry_over_to_kept_and_moved_segments(geometries):
    base, moved = geometries[0], geometries[1]
    values = np.random.default_rng(1).standard_normal((len(base), 3))
    carried = carried_unknowns(base, values, moved)
    old_index, new_index = match_segments(base, moved)
    np.testing.assert_array_equal(carried[new_index], values[old_index])
    loose = np.setdiff1d(np.flatnonzero(~moved.on_border), new_index)
    assert len(loose) > 0
    for i in loose:  # each takes a value of a segment of the same curve
        same_curve = np.flatnonzero(base.origin[:, 0] == moved.origin[i, 0])
        assert any(np.array_equal(carried[i], values[j]) for j in same_curve)


def test_a_singular_update_says_so(geometries, monkeypatch):
    base = geometries[0]
    solver = solver_for(base, True, monkeypatch)
    doubled = base.take(np.r_[np.arange(len(base)), np.flatnonzero(~base.on_border)[:4]])  # segments twice
    updated = updated_solver(solver, base, doubled, solver.operator.lattice)
    with pytest.raises(np.linalg.LinAlgError):
        updated.solve(_rhs(doubled))
