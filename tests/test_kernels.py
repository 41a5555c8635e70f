"""Segment integrals against quadrature, and compiled kernels against the numpy reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from fmr_editor.engine.bem import assemble, assemble_reference
from fmr_editor.engine.kernels import direct_sum, near_sum
from fmr_editor.engine.lattice import Lattice, sort_into_cells
from fmr_editor.engine.layers import direct_sum_reference, pair_integrals
from fmr_editor.engine.segments import Segments


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
