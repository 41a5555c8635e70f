"""The engine's FMM on point charges and dipoles against the direct sum (bench/point_fmm.py)."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from point_fmm import _log_parts, _log_series, _p2m, evaluate_points_fmm, evaluate_points_reference, fmm_levels

from fmr_editor.engine.fmm.expansions import multipole_moments_reference

# Worst relative error measured over 4 seeds, 1e3-1e4 sources, sources as targets and separate
# targets, depths 2-5 and automatic (l2 and max norms): order 6: 9.8e-5, 10: 2.4e-6, 16: 2.4e-8.
# The bounds keep a margin of about 8-10x.
BOUNDS = {6: 1e-3, 10: 2e-5, 16: 2e-7}


def random_problem(seed, n, m=0):
    """Sources in an offset square (not at the origin), charges, dipoles and ``m`` separate targets."""
    rng = np.random.default_rng(seed)
    sources = rng.uniform(0, 100, (n, 2)) + [30, -50]
    charges = rng.normal(size=n)
    dipoles = rng.normal(size=(n, 2))
    # Targets overhang the sources' square, so the lattice covers both.
    targets = rng.uniform(0, 120, (m, 2)) + [20, -60] if m else None
    return sources, charges, dipoles, targets


def relative_error(got, expected):
    return max(np.linalg.norm(got - expected) / np.linalg.norm(expected),
               np.abs(got - expected).max() / np.abs(expected).max())


@pytest.mark.parametrize("n, m", [(1000, 0), (10000, 0), (3000, 2000)])
def test_fmm_matches_direct_sum_and_error_falls_with_order(n, m):
    sources, charges, dipoles, targets = random_problem(n + m, n, m)
    expected = evaluate_points_reference(sources, charges, dipoles, targets)
    errors = [relative_error(evaluate_points_fmm(sources, charges, dipoles, targets, order=order), expected)
              for order in BOUNDS]
    for (order, bound), error in zip(BOUNDS.items(), errors):
        assert error < bound, (order, error)
    # Measured ratios 40-200 between successive orders.
    assert errors[1] < errors[0] / 10 and errors[2] < errors[1] / 10, errors


@pytest.mark.parametrize("levels", [2, 3, 5])
def test_any_depth_gives_the_same_field(levels):
    sources, charges, dipoles, targets = random_problem(7, 2000, 500)
    expected = evaluate_points_reference(sources, charges, dipoles, targets)
    got = evaluate_points_fmm(sources, charges, dipoles, targets, levels=levels, order=16)
    assert relative_error(got, expected) < BOUNDS[16]


def test_clustered_sources_and_empty_input():
    rng = np.random.default_rng(11)
    sources = np.concatenate([rng.normal(0, 0.01, (2000, 2)), rng.uniform(-1, 1, (200, 2))])
    charges, dipoles = rng.normal(size=2200), rng.normal(size=(2200, 2))
    expected = evaluate_points_reference(sources, charges, dipoles)
    assert relative_error(evaluate_points_fmm(sources, charges, dipoles, levels=6), expected) < BOUNDS[16]
    assert evaluate_points_fmm(np.zeros((0, 2)), None, None, np.ones((3, 2))).tolist() == [0.0, 0.0, 0.0]
    assert evaluate_points_fmm(sources, charges, dipoles, np.zeros((0, 2))).shape == (0,)


def test_charges_only_dipoles_only_and_complex_dipoles():
    sources, charges, dipoles, _ = random_problem(3, 2000)
    for c, d in ((charges, None), (None, dipoles), (charges, dipoles[:, 0] + 1j * dipoles[:, 1])):
        expected = evaluate_points_reference(sources, c, d)
        assert relative_error(evaluate_points_fmm(sources, c, d, order=16), expected) < BOUNDS[16]
    as_vectors = evaluate_points_fmm(sources, charges, dipoles, order=10)
    as_complex = evaluate_points_fmm(sources, charges, dipoles[:, 0] + 1j * dipoles[:, 1], order=10)
    np.testing.assert_array_equal(as_vectors, as_complex)


def test_kernel_is_fmm2d_rfmm2d():
    """u = c ln|x - y| - d.(x - y)/|x - y|^2 (fmm2d rfmm2d with dipstr * dipvec = d), own term dropped."""
    sources = np.array([[0.0, 0.0], [3.0, 4.0]])
    charges = np.array([2.0, 0.0])
    dipoles = np.array([[0.0, 0.0], [1.0, -2.0]])
    targets = np.array([[0.0, 0.0], [6.0, 8.0], [1.0, 1.0]])
    expected = []
    for x in targets:
        u = 0.0
        for y, c, d in zip(sources, charges, dipoles):
            r = x - y
            if r @ r > 0:
                u += c * np.log(np.hypot(*r)) - d @ r / (r @ r)
        expected.append(u)
    np.testing.assert_allclose(evaluate_points_reference(sources, charges, dipoles, targets), expected, rtol=1e-14)
    far_field_error = 1e-7  # some pairs are 2 cells apart at depth 2: truncation at order 16
    np.testing.assert_allclose(evaluate_points_fmm(sources, charges, dipoles, targets, levels=2), expected,
                               rtol=far_field_error)


def test_coincident_sources_are_left_out_at_their_own_position():
    rng = np.random.default_rng(5)
    sources = rng.uniform(0, 1, (1500, 2))
    sources[1000:1100] = sources[:100]  # duplicates: both copies drop out at that position
    charges, dipoles = rng.normal(size=1500), rng.normal(size=(1500, 2))
    expected = evaluate_points_reference(sources, charges, dipoles)
    assert np.isfinite(expected).all()
    got = evaluate_points_fmm(sources, charges, dipoles, sources, order=16)  # targets given explicitly
    assert relative_error(got, expected) < BOUNDS[16]


def test_point_multipole_is_the_limit_of_a_short_segment():
    """The point P2M equals ``expansions.multipole_moments_reference`` of a tiny segment with E h = c, C h n0 = -d."""
    rng = np.random.default_rng(2)
    count, order, size, h = 20, 12, 2.0, 1e-7
    centre = np.array([1.0, 1.0])  # the one cell of a 1x1 lattice of side 2
    points = centre + rng.uniform(-0.9, 0.9, (count, 2))
    charges, dipoles = rng.normal(size=count), rng.normal(size=(count, 2))
    d = dipoles[:, 0] + 1j * dipoles[:, 1]
    normal = -d / np.abs(d)  # n0 along -d, so that C = |d| / h is real
    tangent = 1j * normal  # n0 = -i t
    p = points - 0.5 * h * np.stack([tangent.real, tangent.imag], axis=1)
    q = points + 0.5 * h * np.stack([tangent.real, tangent.imag], axis=1)
    flux = np.repeat((charges / h)[:, None], 3, axis=1)
    jump = np.repeat((np.abs(d) / h)[:, None], 3, axis=1)
    expected = multipole_moments_reference(p, q, flux, jump, np.broadcast_to(centre, p.shape), size,
                                           order).sum(axis=0)[0]
    got = np.zeros((1, order + 1), complex)
    _p2m(points[:, 0].copy(), points[:, 1].copy(), charges, dipoles[:, 0].copy(), dipoles[:, 1].copy(),
         np.array([0, count]), 1, size, order, got)
    np.testing.assert_allclose(got[0], expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())


@numba.njit
def _fast_log(values, out):
    for i in range(values.shape[0]):
        k, m = _log_parts(values[i])
        out[i] = _log_series(k, (m - 1.0) / (m + 1.0))


def test_vectorisable_logarithm_is_accurate():
    rng = np.random.default_rng(0)
    values = np.concatenate([np.exp(rng.uniform(-700, 700, 10**5)), rng.uniform(0.5, 2.0, 10**5),
                             1 + rng.normal(0, 1e-9, 1000), [1.0, 2.0, 0.5, np.sqrt(0.5), np.sqrt(2.0)]])
    got = np.empty_like(values)
    _fast_log(values, got)
    expected = np.log(values)
    assert np.all(np.abs(got - expected) <= 4e-16 * np.maximum(np.abs(expected), 1.0))


def test_depth_model_puts_tens_of_sources_in_a_cell():
    for n in (10**4, 10**5, 10**6):
        levels = fmm_levels(n, n, 16)
        assert 8 <= n / 4**levels <= 64, (n, levels)
