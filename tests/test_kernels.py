"""Segment integrals against quadrature, and compiled kernels against the numpy reference."""

from __future__ import annotations

from dataclasses import fields, replace

import numba
import numpy as np
import pytest
from scipy.integrate import quad

from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels.fastmath import FAST_MATH, POLY_MATH
from fmr_editor.engine.kernels.potentials import direct_sum_reference, pair_integrals
from fmr_editor.engine.kernels.segment_sums import direct_sum, near_sum, segment_potentials
from fmr_editor.engine.solve.dense import assemble, assemble_reference


def random_segments(rng: np.random.Generator, count: int, extent: float, length: float) -> Segments:
    p = rng.uniform(0, extent, (count, 2))
    q = p + rng.normal(0, length, (count, 2))
    border = rng.random(count) < 0.3
    return Segments(p, q, rng.normal(size=(count, 3)), rng.normal(size=(count, 3)), border, rng.normal(size=(count, 3)))


def quadrature(target: np.ndarray, p: np.ndarray, q: np.ndarray) -> tuple[float, float]:
    """S and D of one segment by adaptive quadrature of their definitions."""
    d = q - p
    h = np.hypot(*d)
    t = d / h
    n = np.array([t[1], -t[0]])

    def point(s):
        return p + s * t

    single = quad(lambda s: np.log(np.hypot(*(target - point(s)))), 0, h, limit=200)[0]
    def double_kernel(s):
        r = point(s) - target
        return (r @ n) / (r @ r)

    double = quad(double_kernel, 0, h, limit=200)[0]
    return single / (2 * np.pi), double / (2 * np.pi)


@pytest.mark.parametrize("offset", [(0.3, 0.7), (3.0, -2.0), (-1.5, 0.01), (12.0, 40.0), (0.5, -1e-3)])
def test_closed_forms_match_quadrature(offset):
    p, q = np.array([1.0, 2.0]), np.array([3.5, 1.0])
    target = 0.5 * (p + q) + np.array(offset)
    single, double = pair_integrals(target[None], p[None], q[None])
    expected = quadrature(target, p, q)
    np.testing.assert_allclose([single[0, 0], double[0, 0]], expected, rtol=1e-8, atol=1e-10)


def test_double_layer_jumps_by_minus_one_from_right_to_left():
    p, q = np.array([[0.0, 0.0]]), np.array([[4.0, 0.0]])
    # along +x the left normal is (0, -1): left is y < 0
    _, double = pair_integrals(np.array([[2.0, -1e-9], [2.0, 1e-9], [2.0, 0.0]]), p, q)
    np.testing.assert_allclose(double[:, 0], [-0.5, 0.5, 0.0], atol=1e-8)


def test_self_single_layer_matches_its_closed_form():
    p, q = np.array([[0.0, 0.0]]), np.array([[0.6, 0.8]])
    single, _ = pair_integrals(0.5 * (p + q), p, q)
    h = 1.0
    assert single[0, 0] == pytest.approx((h * np.log(h / 2) - h) / (2 * np.pi), rel=1e-12)


def test_compiled_direct_sum_matches_reference():
    rng = np.random.default_rng(4)
    seg = random_segments(rng, 300, 50.0, 2.0)
    targets = rng.uniform(-5, 55, (500, 2))
    targets[:5] = seg.p[:5]  # end points: the logarithm's guard
    targets[5:10] = seg.midpoints[5:10]
    expected = direct_sum_reference(targets, seg.p, seg.q, seg.flux, seg.jump)
    got = direct_sum(targets, seg.p, seg.q, seg.flux, seg.jump)
    # on-segment targets are one-sided in the compiled kernel (a side value), the principal value in the reference
    off = np.ones(len(targets), bool)
    off[5:10] = False
    np.testing.assert_allclose(got[off], expected[off], rtol=1e-9, atol=1e-9)


def test_near_sum_equals_direct_sum_over_the_3x3_block():
    rng = np.random.default_rng(5)
    lattice = Lattice(3, 64.0)
    seg, start = sort_into_cells(random_segments(rng, 400, 64.0, 0.5), lattice)
    targets = rng.uniform(0, 64, (300, 2))
    got = near_sum(targets, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    seg_cells = lattice.cell_of(seg.midpoints)
    for target, value in zip(targets, got):
        cell = lattice.cell_of(target[None])[0]
        near = np.abs(seg_cells - cell).max(axis=1) <= 1
        expected = direct_sum_reference(target[None], seg.p[near], seg.q[near], seg.flux[near], seg.jump[near])
        np.testing.assert_allclose(value, expected[0], rtol=1e-9, atol=1e-9)


def test_compiled_assembly_matches_reference():
    rng = np.random.default_rng(6)
    seg = random_segments(rng, 200, 30.0, 1.0)
    matrix, rhs = assemble(seg)
    expected_matrix, expected_rhs = assemble_reference(seg, chunk=37)
    np.testing.assert_allclose(matrix, expected_matrix, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(rhs, expected_rhs, rtol=1e-9, atol=1e-11)


def block_mask(lattice: Lattice, targets: np.ndarray, seg: Segments) -> np.ndarray:
    """``(m, n)``: segment j's midpoint lies in the 3x3 cells around target i."""
    cells, seg_cells = lattice.cell_of(targets), lattice.cell_of(seg.midpoints)
    return np.abs(cells[:, None, :] - seg_cells[None, :, :]).max(axis=2) <= 1


def on_line_targets(rng: np.random.Generator, seg: Segments, count: int) -> np.ndarray:
    """Targets on segments' own lines outside them or on their end points.

    (Not inside a segment: there the kernels' rounded cross product picks a
    side, the reference's may give the principal value.)
    """
    pick = rng.integers(0, len(seg), count)
    where = rng.choice([0.0, 1.0, -0.5, 1.5], count)
    return seg.p[pick] + where[:, None] * (seg.q[pick] - seg.p[pick])


def _layers_loop_with(flags, error_model):
    @numba.njit(fastmath=flags, error_model=error_model)
    def loop(targets, p, q, tangent, length, single, double):
        for i in range(targets.shape[0]):
            for j in range(p.shape[0]):
                single[i, j], double[i, j] = segment_potentials(targets[i, 0], targets[i, 1], p[j, 0], p[j, 1],
                                                                q[j, 0], q[j, 1], tangent[j, 0], tangent[j, 1],
                                                                length[j])
    return loop


@pytest.mark.parametrize("flags, error_model", [(POLY_MATH, "numpy"), (FAST_MATH, "python")],
                         ids=["poly-math", "fast-math-python-errors"])
def test_scalar_layers_match_the_reference_everywhere(flags, error_model):
    """``segment_potentials`` (inlined, so compiled with its caller's options) against ``pair_integrals``.

    Off the segment both agree; on a segment's line outside it and at its end
    points the double layer is 0 in both and the single layer is finite; on the
    segment itself ``segment_potentials`` gives 0 too (the reference: the principal value,
    also 0).  Under numba's "python" error model nothing raises.
    """
    rng = np.random.default_rng(7)
    seg = random_segments(rng, 60, 20.0, 1.5)
    # axis-parallel segments hold exact on-segment targets (their cross products are exactly 0)
    seg.p[:4] = [[1.0, 2.0], [5.0, 2.0], [3.0, -1.0], [3.0, 7.5]]
    seg.q[:4] = [[5.0, 2.0], [1.0, 2.0], [3.0, 7.5], [3.0, -1.0]]
    inside = np.array([[2.5, 2.0], [3.0, 2.0], [3.0, 0.25], [3.0, 6.0]])
    targets = np.concatenate([rng.uniform(-5, 25, (200, 2)), on_line_targets(rng, seg, 100), inside])
    tangent = (seg.q - seg.p) / np.hypot(*(seg.q - seg.p).T)[:, None]
    length = np.hypot(*(seg.q - seg.p).T)
    single = np.empty((len(targets), len(seg)))
    double = np.empty_like(single)
    _layers_loop_with(flags, error_model)(targets, seg.p, seg.q, tangent, length, single, double)
    expected_single, expected_double = pair_integrals(targets, seg.p, seg.q)
    assert np.isfinite(single).all() and np.isfinite(double).all()
    np.testing.assert_allclose(single, expected_single, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(double, expected_double, rtol=1e-12, atol=1e-14)


def test_compiled_direct_sum_over_many_segments_matches_reference():
    """More segments than one scratch tile, and targets on segments' lines (the guards)."""
    rng = np.random.default_rng(8)
    seg = random_segments(rng, 1300, 80.0, 1.0)
    targets = np.concatenate([rng.uniform(-5, 85, (150, 2)), seg.p[:10], seg.q[20:30]])
    expected = direct_sum_reference(targets, seg.p, seg.q, seg.flux, seg.jump)
    got = direct_sum(targets, seg.p, seg.q, seg.flux, seg.jump)
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-10)
    assert direct_sum(targets, seg.p[:0], seg.q[:0], seg.flux[:0], seg.jump[:0]).tolist() == [[0.0] * 3] * len(targets)


def test_near_sum_with_own_segments_matches_the_principal_value_reference():
    """Targets on segment midpoints (own), end points and lines; a crowded cell; unsorted targets."""
    rng = np.random.default_rng(9)
    lattice = Lattice(3, 64.0)
    crowd = random_segments(rng, 90, 6.0, 0.4)  # a block far larger than the others
    crowd = replace(crowd, p=crowd.p + 20, q=crowd.q + 20)
    spread = random_segments(rng, 300, 64.0, 0.5)
    both = {field.name: np.concatenate([getattr(spread, field.name), getattr(crowd, field.name)])
            for field in fields(Segments)}
    seg, start = sort_into_cells(Segments(**both), lattice)
    mids = seg.midpoints
    targets = np.concatenate([mids, on_line_targets(rng, seg, 200), rng.uniform(0, 64, (200, 2))])
    own = np.concatenate([np.arange(len(seg)), np.full(400, -1)])
    shuffle = rng.permutation(len(targets))
    targets, own = targets[shuffle], own[shuffle]
    got = near_sum(targets, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump, own)
    single, double = pair_integrals(targets, seg.p, seg.q)
    double[own >= 0, own[own >= 0]] = 0.0
    near = block_mask(lattice, targets, seg)
    expected = (single * near) @ seg.flux - (double * near) @ seg.jump
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)


def test_compiled_assembly_over_many_segments_matches_reference():
    """More segments than one scratch tile."""
    rng = np.random.default_rng(11)
    seg = random_segments(rng, 1100, 60.0, 1.0)
    matrix, rhs = assemble(seg)
    expected_matrix, expected_rhs = assemble_reference(seg)
    np.testing.assert_allclose(matrix, expected_matrix, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(rhs, expected_rhs, rtol=1e-9, atol=1e-10)
