"""Diffusion points (fast Gauss transform into cell polynomials plus exact near points) against the direct sum."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numpy.polynomial.hermite import hermval

from fmr_editor.engine.fmm.lattice import Lattice
from fmr_editor.engine.points.gauss import (
    RHO_GRID,
    GaussPoints,
    PointSettings,
    changed_cells,
    cutoff_radii,
    expansion_ratios,
    gaussian_sum_reference,
    max_cell_ratio,
    scaled_hermite,
    shift_matrices,
    truncation_error,
)
from fmr_editor.engine.points.increments import add_to_tensor
from fmr_editor.engine.points.near import evaluate_at, evaluate_grid, near_at, near_grid, near_points
from fmr_editor.engine.points.tensor import point_polynomials, point_polynomials_reference
from fmr_editor.model.point import DiffusionPoint

#: The accuracy target: half a level of an 8-bit channel.
TARGET = 0.5 / 255


def random_points(rng, count, side, r_min=0.5, r_max=200.0, margin=0.0, amplitude=1.0):
    """Log-uniform radii, colours in [0, 1], centres over the square (overhanging it by ``margin``)."""
    return GaussPoints(
        rng.uniform(-margin, side + margin, (count, 2)),
        np.exp(rng.uniform(math.log(r_min), math.log(r_max), count)),
        amplitude * rng.uniform(0, 1, (count, 3)),
    )


def sample_grid(lattice, per_cell=8):
    """Sorted coordinates hitting every cell edge (and so every corner) plus interior points."""
    n, size = lattice.cells_per_side, lattice.cell_size
    return np.sort(np.concatenate([np.arange(n + 1) * size, (np.arange(n * per_cell) + 0.37) * size / per_cell]))


def field(points, lattice, settings):
    return point_polynomials(points, lattice, settings), near_points(points, lattice, settings)


def direct_on_grid(points, xs, ys):
    targets = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)
    return gaussian_sum_reference(targets, points.positions, points.radii, points.weights).reshape(len(ys), len(xs), 3)


# --- Series, error table and rules ------------------------------------------------------


def test_hermite_recurrence_matches_closed_forms():
    s = np.linspace(-6, 6, 241)
    rho = 0.7
    u = scaled_hermite(s, rho, 20)
    for n in range(21):
        # physicists' Hermite polynomial H_n: h_n = exp(-s^2) H_n(s)
        closed = np.exp(-s * s) * hermval(s, np.eye(21)[n]) * rho**n / math.factorial(n)
        np.testing.assert_allclose(u[:, n], closed, rtol=1e-11, atol=1e-13 * np.abs(closed).max())
    np.testing.assert_allclose(u[:, 1], 2 * s * rho * np.exp(-s * s), rtol=1e-15)
    # the series itself: exp(-(rho xi - s)^2) = sum_n u_n(s) xi^n
    xi = np.linspace(-0.5, 0.5, 11)
    series = np.polynomial.polynomial.polyval(xi, scaled_hermite(s, rho, 40).T, tensor=True)
    np.testing.assert_allclose(series, np.exp(-(rho * xi[None, :] - s[:, None]) ** 2), atol=1e-14)


@pytest.mark.parametrize("order", [8, 12])
def test_truncation_table_holds_on_a_finer_sampling_and_in_two_dimensions(order):
    rng = np.random.default_rng(order)
    table = truncation_error(order)
    for rho in (0.5, 0.9, 1.3):
        e1 = np.interp(rho, RHO_GRID, table)  # the grid ratio at or below rho errs less
        s = np.arange(-8, 8, 0.002)
        xi = np.linspace(-0.5, 0.5, 129)
        u = scaled_hermite(s, rho, order)
        one = np.abs(u @ (xi[None, :] ** np.arange(order + 1)[:, None]) - np.exp(-(rho * xi - s[:, None]) ** 2))
        assert one.max() <= e1 * 1.02, (rho, one.max(), e1)
        for _ in range(20):
            sx, sy = rng.uniform(-3, 3, 2)
            ux, uy = scaled_hermite(sx, rho, order), scaled_hermite(sy, rho, order)
            powers = xi[:, None] ** np.arange(order + 1)
            approx = (powers @ ux)[:, None] * (powers @ uy)[None, :]
            exact = np.exp(-(rho * xi[:, None] - sx) ** 2 - (rho * xi[None, :] - sy) ** 2)
            assert np.abs(approx - exact).max() <= e1 * (2 + e1)


def test_split_rule_and_dropped_points():
    lattice = Lattice(4, 128.0)
    settings = PointSettings(order=8, tolerance=1e-5)
    rho = float(max_cell_ratio(8, 1e-5))
    radii = np.array([0.5, 0.99 * 8 / rho, 1.01 * 8 / rho, 2.2 * 8 / rho, 200.0, 5.0])
    weights = np.ones((6, 3))
    weights[5] = 0.5e-5  # at most the tolerance everywhere: dropped
    points = GaussPoints(np.full((6, 2), 60.0), radii, weights)
    assert expansion_ratios(points, lattice, settings).tolist() == [0, 0, 1, 2, 16, -1]
    assert (changed_cells(points, lattice, settings)[5] == 0).all()
    assert cutoff_radii(points, 1e-5)[5] == 0


def test_a_point_of_zero_or_subnormal_weight_is_dropped_without_a_warning():
    weights = np.array([[0.0, 0.0, 0.0], [1e-320, 0.0, 0.0], [1.0, 0.0, 0.0]])  # 1e-5 / 1e-320 overflows
    points = GaussPoints(np.full((3, 2), 60.0), np.full(3, 5.0), weights)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ratios = expansion_ratios(points, Lattice(4, 128.0), PointSettings(order=8, tolerance=1e-5))
    assert ratios[:2].tolist() == [-1, -1] and ratios[2] >= 0


def test_contributions_outside_the_changed_cells_are_below_tolerance():
    """Brute force: every sample outside a point's rectangle of fine cells sees less than the tolerance."""
    rng = np.random.default_rng(3)
    lattice = Lattice(5, 256.0)
    settings = PointSettings(order=8, tolerance=1e-5)
    points = random_points(rng, 60, 256.0, margin=30.0)
    rectangles = changed_cells(points, lattice, settings)
    xs = ys = sample_grid(lattice, per_cell=4)
    size, n = lattice.cell_size, lattice.cells_per_side
    cols = np.clip(np.floor(xs / size).astype(int), 0, n - 1)  # the cell a sample is evaluated in
    rows = np.clip(np.floor(ys / size).astype(int), 0, n - 1)
    for i, (a, b, c, d) in enumerate(rectangles):
        one = direct_on_grid(points.take([i]), xs, ys)
        inside = ((rows >= a) & (rows < b))[:, None] & ((cols >= c) & (cols < d))[None, :]
        outside = np.abs(one[~inside]).max(initial=0.0)
        assert outside <= settings.tolerance, (i, outside)
        # and each point errs by at most the tolerance everywhere (truncation inside, cutoff outside)
        got = evaluate_grid(*field(points.take([i]), lattice, settings), xs, ys)
        assert np.abs(got - one).max() <= settings.tolerance, i


# --- Fast paths against their references -------------------------------------------------


@pytest.mark.parametrize("order, tolerance", [(8, 1e-5), (12, 1e-6)])
def test_compiled_build_and_incremental_add_match_the_numpy_reference(order, tolerance):
    rng = np.random.default_rng(order)
    lattice = Lattice(4, 128.0)
    settings = PointSettings(order=order, tolerance=tolerance)
    points = random_points(rng, 150, 128.0, r_min=4.0, margin=20.0)
    reference = point_polynomials_reference(points, lattice, settings)
    scale = np.abs(reference).max()
    np.testing.assert_allclose(point_polynomials(points, lattice, settings), reference, rtol=0, atol=1e-13 * scale)
    added = np.zeros_like(reference)
    add_to_tensor(added, points, lattice, settings)
    np.testing.assert_allclose(added, reference, rtol=0, atol=1e-13 * scale)


def test_every_grid_ratio_alone_and_in_pairs_matches_the_reference():
    lattice = Lattice(4, 128.0)
    settings = PointSettings()
    rho = float(max_cell_ratio(settings.order, settings.tolerance))
    for ratios in ([1], [3], [1, 3], [2, 6], [12], [16, 6]):
        radii = [1.1 * m * lattice.cell_size / rho for m in ratios]
        points = GaussPoints([[40.0, 50.0], [70.3, 81.0]][: len(ratios)], radii, np.ones((len(ratios), 3)))
        assert expansion_ratios(points, lattice, settings).tolist() == ratios
        reference = point_polynomials_reference(points, lattice, settings)
        np.testing.assert_allclose(point_polynomials(points, lattice, settings), reference, rtol=0, atol=1e-13)


def test_shift_matrices_reexpand_exactly():
    order, ratio = 8, 3
    rng = np.random.default_rng(0)
    coarse = rng.normal(size=order + 1)
    shift = shift_matrices(ratio, order)
    for b in range(ratio):
        xi_fine = np.linspace(-0.5, 0.5, 7)
        xi_coarse = (b + 0.5 + xi_fine) / ratio - 0.5
        np.testing.assert_allclose(np.polynomial.polynomial.polyval(xi_fine, shift[b] @ coarse),
                                   np.polynomial.polynomial.polyval(xi_coarse, coarse), atol=1e-14)


def test_near_grid_matches_near_at_and_the_direct_sum():
    rng = np.random.default_rng(4)
    lattice = Lattice(4, 128.0)
    settings = PointSettings()
    points = random_points(rng, 300, 128.0, r_max=6.0, margin=10.0)
    near = near_points(points, lattice, settings)
    assert len(near) == len(points)
    xs, ys = sample_grid(lattice, 3), sample_grid(lattice, 2)[5:-7]
    grid = near_grid(near, xs, ys)
    targets = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)
    np.testing.assert_allclose(grid.reshape(-1, 3), near_at(near, targets), rtol=1e-13, atol=1e-14)
    assert np.abs(grid - direct_on_grid(points, xs, ys)).max() < 300 * settings.tolerance


# --- Accuracy against the direct sum ---------------------------------------------------------


@pytest.mark.parametrize("radius", [0.5, 1.0, 3.0, 7.5, 11.0, 40.0, 200.0])
@pytest.mark.parametrize("order", [8, 12])
def test_single_points_at_edges_corners_and_outside(radius, order):
    lattice = Lattice(5, 256.0)
    settings = PointSettings(order=order)
    positions = np.array([[128.0, 128.0], [96.0, 100.3], [3.7, 250.1], [-5.0, 40.0], [300.0, 270.0]])
    xs = ys = sample_grid(lattice)
    for position in positions:
        point = GaussPoints(position[None], [radius], [[1.0, 0.5, 0.25]])
        got = evaluate_grid(*field(point, lattice, settings), xs, ys)
        assert np.abs(got - direct_on_grid(point, xs, ys)).max() <= settings.tolerance


@pytest.mark.parametrize("count", [1, 10, 1000])
@pytest.mark.parametrize("order, levels", [(8, 5), (12, 5), (8, 4), (8, 6)])  # cells of 8, 16 and 4 px
def test_many_points_on_a_dense_grid(count, order, levels):
    rng = np.random.default_rng(count + order + levels)
    lattice = Lattice(levels, 256.0)
    settings = PointSettings(order=order)
    points = random_points(rng, count, 256.0, margin=40.0)
    xs = ys = sample_grid(lattice, per_cell=4)
    got = evaluate_grid(*field(points, lattice, settings), xs, ys)
    error = np.abs(got - direct_on_grid(points, xs, ys)).max()
    assert error <= TARGET, error


def test_negative_amplitudes():
    rng = np.random.default_rng(9)
    lattice = Lattice(5, 256.0)
    settings = PointSettings()
    points = random_points(rng, 200, 256.0)
    points = GaussPoints(points.positions, points.radii, points.weights * rng.choice([-2.0, 1.0], (200, 1)))
    xs = ys = sample_grid(lattice, per_cell=2)
    got = evaluate_grid(*field(points, lattice, settings), xs, ys)
    assert np.abs(got - direct_on_grid(points, xs, ys)).max() <= TARGET


def test_hundred_thousand_points_on_a_subsample():
    """1e5 points over a 1024 px canvas (sums of some 400-500 a channel), checked on 2,000 samples."""
    rng = np.random.default_rng(100_000)
    lattice = Lattice(7, 1024.0)
    settings = PointSettings()
    points = random_points(rng, 100_000, 1024.0)
    poly, near = field(points, lattice, settings)
    size, n = lattice.cell_size, lattice.cells_per_side
    targets = np.concatenate([
        rng.uniform(0, 1024, (1400, 2)),
        rng.integers(0, n + 1, (300, 2)) * size,  # corners
        np.stack([rng.integers(0, n + 1, 300) * size, rng.uniform(0, 1024, 300)], axis=1),  # edges
    ])
    expected = gaussian_sum_reference(targets, points.positions, points.radii, points.weights)
    error = np.abs(evaluate_at(poly, near, targets) - expected).max()
    assert error <= TARGET, error


# --- Incremental updates ---------------------------------------------------------------------


def test_adding_then_removing_points_restores_the_coefficients():
    rng = np.random.default_rng(12)
    lattice = Lattice(6, 512.0)
    settings = PointSettings()
    tensor = point_polynomials(random_points(rng, 5000, 512.0, r_min=8.0), lattice, settings)
    before = tensor.copy()
    dab = random_points(rng, 20, 512.0, r_min=4.0, r_max=80.0, amplitude=3.0)
    rectangles = add_to_tensor(tensor, dab, lattice, settings)
    changed = np.abs(tensor - before).max(axis=(2, 3, 4)) > 0
    mask = np.zeros_like(changed)
    for a, b, c, d in rectangles:
        mask[a:b, c:d] = True
    assert changed.any() and not (changed & ~mask).any()
    add_to_tensor(tensor, dab.negated(), lattice, settings)
    assert np.abs(tensor - before).max() <= 1e-12


def test_removing_a_point_of_a_batch_build():
    rng = np.random.default_rng(13)
    lattice = Lattice(5, 256.0)
    settings = PointSettings()
    points = random_points(rng, 400, 256.0, r_min=8.0)
    tensor = point_polynomials(points, lattice, settings)
    add_to_tensor(tensor, points.take([7]).negated(), lattice, settings)
    without = point_polynomials(points.take(np.arange(400) != 7), lattice, settings)
    np.testing.assert_allclose(tensor, without, rtol=0, atol=1e-12 * np.abs(without).max())


def test_live_points_copy_only_the_rows_their_points_reached_and_never_change_a_handed_out_tensor():
    from fmr_editor.engine.points.field import LivePoints, changed_point_cells

    rng = np.random.default_rng(14)
    lattice, order = Lattice(7, 512.0), 8

    def dab(y: float, count: int = 3) -> list[DiffusionPoint]:
        xs, radii, amplitudes = rng.uniform(100, 400, count), rng.uniform(0.5, 30, count), rng.uniform(-1, 1, count)
        return [DiffusionPoint((float(x), y), float(r), (1.0, 0.5, 0.2), float(a))
                for x, r, a in zip(xs, radii, amplitudes)]

    first = tuple(dab(120.0))
    live = LivePoints(first, lattice, order)
    held = [(live.tensor, live.tensor.copy())]
    points, removed = list(first), []
    for y in (130.0, 300.0, 140.0):  # a stroke, a dab far below it, the stroke again; then one point removed
        added = dab(y)
        points += added
        live.update(tuple(points), [], added)
        held.append((live.tensor, live.tensor.copy()))
    removed = [points.pop(1)]
    live.update(tuple(points), removed, [])
    fresh = LivePoints(tuple(points), lattice, order)
    np.testing.assert_allclose(live.tensor, fresh.tensor, rtol=0, atol=1e-12 * np.abs(fresh.tensor).max())
    reached = np.flatnonzero(np.abs(live.tensor).max(axis=(1, 2, 3, 4)) > 0)
    first_row, last_row = live.rows
    assert first_row <= reached.min() and reached.max() < last_row  # zero outside the rows it copies
    assert last_row - first_row < lattice.cells_per_side  # less than the whole
    for tensor, copy in held:  # what ``field`` handed out stays as it was
        np.testing.assert_array_equal(tensor, copy)
    before = LivePoints(first, lattice, order)  # an undo's comparison reads the rows either reached alone
    near_a, near_b = before.field().near, live.field().near
    occupied = (np.diff(near_a.cell_start) > 0) | (np.diff(near_b.cell_start) > 0)
    expected = np.any(before.tensor != live.tensor, axis=(2, 3, 4)) | occupied.reshape(before.tensor.shape[:2])
    np.testing.assert_array_equal(changed_point_cells(before, live), expected)


# --- Model and packing -------------------------------------------------------------------


def test_diffusion_point_validation_equality_and_packing():
    point = DiffusionPoint((1, 2.5), 3, (0.1, 0.2, 0.3), amplitude=-2)
    assert point == DiffusionPoint((1.0, 2.5), 3.0, (0.1, 0.2, 0.3), -2.0)
    assert hash(DiffusionPoint((-0.0, 0.0), 1.0, (0, 0, 0))) == hash(DiffusionPoint((0.0, 0.0), 1.0, (0, 0, 0)))
    assert DiffusionPoint((0, 0), 1.0, (0, 0, 0)).amplitude == 1.0
    for bad in [dict(radius=0.0), dict(radius=-1.0), dict(radius=math.inf), dict(position=(0, math.nan)),
                dict(position=(1, 2, 3)), dict(color=(0, 0)), dict(amplitude=math.nan), dict(color="red")]:
        kwargs = dict(position=(0, 0), radius=1.0, color=(0, 0, 0)) | bad
        with pytest.raises(ValueError):
            DiffusionPoint(**kwargs)
    packed = GaussPoints.from_points([point, DiffusionPoint((4, 5), 6, (1, 1, 0))])
    np.testing.assert_array_equal(packed.positions, [[1, 2.5], [4, 5]])
    np.testing.assert_array_equal(packed.weights, [[-0.2, -0.4, -0.6], [1, 1, 0]])
    assert len(GaussPoints.from_points([])) == 0
    with pytest.raises(ValueError):
        GaussPoints([[0, 0]], [0.0], [[1, 1, 1]])
    with pytest.raises(ValueError):
        GaussPoints([[0, np.nan]], [1.0], [[1, 1, 1]])
