"""The FMM product of the collocation system against the dense matrix."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import circle_points, straight_chain

from fmr_editor.engine.bem import assemble, solve_dense
from fmr_editor.engine.fast_solve import CollocationOperator, solve_fmm
from fmr_editor.engine.lattice import Lattice, sort_into_cells
from fmr_editor.engine.segments import boundary_segments, curve_segments
from fmr_editor.model import ColorStop, DiffusionCurve, Document


@pytest.fixture(scope="module")
def system():
    rng = np.random.default_rng(2)
    curves = []
    for _ in range(5):
        stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 2.0, 4.0))
        curves.append(DiffusionCurve(circle_points(*rng.uniform(25, 100, 2), rng.uniform(6, 20)), left=stops, right=stops[::-1]))
    curves.append(DiffusionCurve(straight_chain([(5, 120), (60, 90), (123, 110)]), left=stops, right=stops))
    doc = Document(128, 128, curves)
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


def test_fmm_right_hand_side_equals_the_dense_one(system):
    segments, cell_start, lattice, _, rhs = system
    got = CollocationOperator(segments, cell_start, lattice, 20).right_hand_side()
    assert np.abs(got - rhs).max() <= 1e-8 * np.abs(rhs).max()


def test_near_matrix_holds_the_dense_entries_of_each_3x3_block(system):
    segments, cell_start, lattice, matrix, _ = system
    near = CollocationOperator(segments, cell_start, lattice, 20).near_matrix().toarray()
    cells = lattice.cell_of(segments.midpoints)
    neighbours = np.abs(cells[:, None, :] - cells[None, :, :]).max(axis=2) <= 1
    np.testing.assert_array_equal(near[neighbours], matrix[neighbours])
    assert not near[~neighbours].any()


def test_iterative_solve_matches_the_dense_solve(system):
    segments, cell_start, lattice, _, _ = system
    solved, report = solve_fmm(segments, cell_start, lattice, order=20, rtol=1e-11)
    dense = solve_dense(segments)
    unknown, expected = solved.unknowns(), dense.unknowns()
    assert report.residual <= 1e-9
    assert np.abs(unknown - expected).max() <= 1e-6 * np.abs(expected).max()
