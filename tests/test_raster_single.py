"""The float32 near field (``kernels.single``) against the float64 one: its error bound, pair by pair and per sample."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from shapes import circle_points
from test_raster import chains_and_strays

from fmr_editor.engine import Settings, build, rasterise
from fmr_editor.engine import representation as representation_module
from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels import grid as grid_module
from fmr_editor.engine.kernels import single
from fmr_editor.engine.kernels.fastmath import POLY_MATH, log_r2, potentials_from
from fmr_editor.engine.kernels.grid import near_field_grid
from fmr_editor.model import ColorStop, DiffusionCurve, Document


@numba.njit(fastmath=POLY_MATH, error_model="numpy")
def _pair_errors(x, y, p, q, out):
    """Per pair: float32 minus float64 single and double layer (cell units), and whether the pair is in doubt."""
    f = np.float32
    for i in range(x.shape[0]):
        px, py, qx, qy = p[i, 0], p[i, 1], q[i, 0], q[i, 1]
        h = np.hypot(qx - px, qy - py)
        tx, ty = (qx - px) / h, (qy - py) / h
        s, d, _ = potentials_from(x[i], y[i], px, py, qx, qy, tx, ty, h, log_r2(x[i], y[i], px, py))
        a, b, c, e, g, k = f(x[i]), f(y[i]), f(px), f(py), f(qx), f(qy)
        s32, d32, _ = single.potentials_single(a, b, c, e, g, k, f(tx), f(ty), f(h), single.log_r2_single(a, b, c, e))
        out[i, 0], out[i, 1] = s32 - s, d32 - d
        out[i, 2] = single.doubt_single(a, b, c, e, g, k)


def column_pairs(rng, count):
    """Samples in a window of three cells, segments in the column of three about the middle cell's centre (cell
    units), a third of the samples close to a segment (down to 1e-9 cells, some exactly on it) or to an end point."""
    x, y = rng.uniform(-1.5, 1.5, count), rng.uniform(-0.5, 0.5, count)
    p = np.stack([rng.uniform(-0.5, 0.5, count), rng.uniform(-1.5, 1.5, count)], axis=1)
    q = np.stack([rng.uniform(-0.5, 0.5, count), np.clip(p[:, 1] + rng.normal(0, 0.5, count), -1.5, 1.5)], axis=1)
    near = count // 3
    t = rng.choice([0.0, 1.0, 0.5, 0.3], near) * (rng.random(near) < 0.3) + rng.random(near) * (rng.random(near) >= 0.3)
    offset = rng.normal(0, 1, (near, 2)) * 10.0 ** rng.uniform(-9, -1, (near, 1)) * (rng.random((near, 1)) < 0.9)
    x[:near], y[:near] = (p[:near] + t[:, None] * (q[:near] - p[:near]) + offset).T
    keep = np.hypot(*(q - p).T) > 1e-6
    return x[keep], y[keep], p[keep], q[keep]


def test_pairs_not_in_doubt_keep_their_error_bound():
    rng = np.random.default_rng(41)
    x, y, p, q = column_pairs(rng, 3_000_000)
    errors = np.empty((len(x), 3))
    _pair_errors(x, y, p, q, errors)
    doubtful = errors[:, 2] > 0
    assert 0.05 < doubtful.mean() < 0.5  # samples on and near segments and end points are in doubt
    fine = errors[~doubtful]
    assert np.isfinite(fine).all()
    assert np.abs(fine[:, 0]).max() <= single.PAIR_SINGLE
    assert np.abs(fine[:, 1]).max() <= single.PAIR_DOUBLE
    assert np.abs(errors[doubtful, 1]).max() > 0.1  # without the doubt, a sample would flip sides


@pytest.fixture(scope="module")
def strays():
    rng = np.random.default_rng(35)
    lattice = Lattice(3, 64.0)
    xs, ys = np.arange(0.25, 64, 1.5), np.arange(0.5, 64, 2.5)
    seg, start = sort_into_cells(chains_and_strays(rng, 64, 64, np.array([xs[4], ys[3]])), lattice)
    return lattice, xs, ys, seg, start


def sample_bounds(lattice, xs, ys, seg, start):
    """``single.error_bounds`` at each sample of the grid."""
    bounds = single.error_bounds(lattice.cells_per_side, lattice.cell_size, start, seg.flux, seg.jump)
    cell = lambda v: np.clip((v // lattice.cell_size).astype(int), 0, lattice.cells_per_side - 1)  # noqa: E731
    return bounds[cell(ys)[:, None], cell(xs)[None, :]]


def test_single_precision_near_field_is_within_a_thousandth_of_a_level(strays):
    lattice, xs, ys, seg, start = strays
    args = (xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    double = near_field_grid(*args)
    single_field = near_field_grid(*args, precision="single")
    assert np.abs(single_field - double).max() > 0  # the float32 kernel ran
    np.testing.assert_allclose(single_field, double, rtol=0, atol=1e-3 / 255)
    assert (np.abs(single_field - double).max(axis=2) <= sample_bounds(lattice, xs, ys, seg, start)).all()
    with pytest.raises(ValueError, match="precision"):
        near_field_grid(*args, precision="half")


def test_samples_on_segments_and_end_points_stay_within_the_bound():
    rng = np.random.default_rng(42)
    lattice = Lattice(3, 64.0)
    p = rng.uniform(4, 60, (40, 2))
    q = p + rng.normal(0, 3, (40, 2))
    q = np.clip(q, 0.5, 63.5)
    segments = Segments(p, q, 0.05 * rng.normal(size=(40, 3)), rng.uniform(-1, 1, (40, 3)), np.zeros(40, bool),
                        rng.normal(size=(40, 3)))
    seg, start = sort_into_cells(segments, lattice)
    # the grid's lines pass through end points and through points inside segments (where the sides meet)
    t = rng.uniform(0.1, 0.9, 20)
    inside = seg.p[:20] + t[:, None] * (seg.q[:20] - seg.p[:20])
    xs = np.unique(np.r_[seg.p[:, 0], inside[:, 0], rng.uniform(0, 64, 30)])
    ys = np.unique(np.r_[seg.p[:, 1], inside[:, 1], rng.uniform(0, 64, 30)])
    args = (xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    double, single_field = near_field_grid(*args), near_field_grid(*args, precision="single")
    assert np.abs(single_field - double).max() > 0
    assert (np.abs(single_field - double).max(axis=2) <= sample_bounds(lattice, xs, ys, seg, start)).all()


def test_cells_over_the_budget_stay_in_double_precision(strays, monkeypatch):
    lattice, xs, ys, seg, start = strays
    args = (xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    double = near_field_grid(*args)
    monkeypatch.setattr("fmr_editor.engine.kernels.grid.SINGLE_BUDGET", 0.0)
    np.testing.assert_array_equal(near_field_grid(*args, precision="single"), double)


def test_error_bounds_sum_the_blocks():
    rng = np.random.default_rng(43)
    lattice = Lattice(2, 32.0)
    count = 30
    p = rng.uniform(0, 32, (count, 2))
    segments = Segments(p, p + 0.1, rng.normal(size=(count, 3)), rng.normal(size=(count, 3)), np.zeros(count, bool),
                        rng.normal(size=(count, 3)))
    seg, start = sort_into_cells(segments, lattice)
    bounds = single.error_bounds(4, 8.0, start, seg.flux, seg.jump)
    cells = lattice.cell_of(seg.midpoints)
    for cy in range(4):
        for cx in range(4):
            block = np.abs(cells - [cy, cx]).max(axis=1) <= 1
            rounding = 0.5 * (block.sum() + 1) * single.ROUNDING
            expected = (8.0 * np.abs(seg.flux[block]).max(axis=1).sum() * (single.PAIR_SINGLE + rounding)
                        + np.abs(seg.jump[block]).max(axis=1).sum() * (single.PAIR_DOUBLE + rounding))
            assert bounds[cy, cx] == pytest.approx(expected, rel=1e-12)


def test_a_representation_keeps_its_bounds_for_every_raster(monkeypatch):
    stops = (ColorStop(0.0, (0.9, 0.2, 0.1)),)
    rep = build(Document(64, 64, (DiffusionCurve(circle_points(32, 30, 20), left=stops),)), Settings(levels=3))
    counted = []

    def counting(*args):
        counted.append(args)
        return single.error_bounds(*args)

    for module in (representation_module, grid_module):
        monkeypatch.setattr(module, "error_bounds", counting)
    first = rasterise(rep, samples=1)  # 8 samples a cell side: the near field's column visits, float32 allowed
    np.testing.assert_array_equal(rasterise(rep, samples=1), first)
    assert len(counted) == 1
    np.testing.assert_array_equal(rep.near_bounds, single.error_bounds(8, 8.0, rep.near[1], rep.near[0].flux,
                                                                       rep.near[0].jump))
