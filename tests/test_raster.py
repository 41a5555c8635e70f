"""Rasterising on the sample grid: the grid kernels against the point-wise kernels and the numpy reference."""

from __future__ import annotations

import math
import tracemalloc

import numba
import numpy as np
import pytest
from shapes import circle_points, straight_chain

from fmr_editor.engine import Settings, build, raster, rasterise
from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells
from fmr_editor.engine.fmm.orders import sample_degrees
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels import grid
from fmr_editor.engine.kernels.fastmath import atan2_poly, log_poly
from fmr_editor.engine.kernels.grid import far_field_grid, near_field_grid
from fmr_editor.engine.kernels.local_grid import local_field_reference
from fmr_editor.engine.kernels.potentials import direct_sum_reference
from fmr_editor.engine.kernels.segment_sums import near_sum
from fmr_editor.engine.raster import far_field_reference, sample_coordinates
from fmr_editor.model import ColorStop, DiffusionCurve, Document


def chains_and_strays(rng: np.random.Generator, width: float, height: float, vertex: np.ndarray) -> Segments:
    """Random polylines (consecutive segments share end points, runs cross cells) plus isolated segments.

    One chain passes exactly through ``vertex`` (a sample of the test grids).
    """
    p, q = [], []
    for start in range(6):
        walk = rng.uniform([4, 4], [width - 4, height - 4]) + np.cumsum(rng.normal(0, 1.2, (40, 2)), axis=0)
        if start == 0:
            walk[17] = vertex
        walk = np.clip(walk, 0.5, [width - 0.5, height - 0.5])
        p.append(walk[:-1])
        q.append(walk[1:])
    stray = rng.uniform([0, 0], [width, height], (60, 2))
    p.append(stray)
    q.append(np.clip(stray + rng.normal(0, 1.0, stray.shape), 0, [width, height]))
    p, q = np.concatenate(p), np.concatenate(q)
    keep = np.hypot(*(q - p).T) > 1e-3
    p, q = p[keep], q[keep]
    count = len(p)
    return Segments(p, q, rng.normal(size=(count, 3)), rng.normal(size=(count, 3)), np.zeros(count, bool),
                    rng.normal(size=(count, 3)))


def near_sum_on_grid(xs, ys, lattice, start, seg):
    targets = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)
    values = near_sum(targets, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    return values.reshape(len(ys), len(xs), 3)


def grid_cases():
    """(name, lattice, canvas width, canvas height, xs, ys)."""
    rng = np.random.default_rng(11)
    square = Lattice(3, 64.0)  # cells of 8 px: every multiple of 8 is an edge, and exact
    wide = Lattice(4, 128.0)  # covers the bounding square of a 128 x 80 canvas
    return [
        # every cell edge, both ends of the lattice included
        ("edges", square, 64, 64, np.arange(0.0, 64.5, 2.0), np.arange(0.0, 64.5, 4.0)),
        # a window over part of the lattice, unequal runs, a repeated coordinate
        ("window", square, 64, 64, np.sort(np.r_[rng.uniform(19.0, 45.0, 23), 24.0, 24.0]),
         np.sort(rng.uniform(3.0, 30.0, 17))),
        # one band of a non-square canvas at 37 x 23 pixels, 3 x 3 samples each
        ("non-square", wide, 128, 80, sample_coordinates(37, 128, 3), sample_coordinates(23, 80, 3)[20:50]),
    ]


@pytest.mark.parametrize("row_samples", [0, 10**9], ids=["columns", "rows"])
@pytest.mark.parametrize("case", grid_cases(), ids=lambda case: case[0])
def test_near_field_grid_equals_near_sum(case, row_samples, monkeypatch):
    monkeypatch.setattr(grid, "ROW_SAMPLES", row_samples)  # either kernel: visits by columns, or by rows of segments
    _, lattice, width, height, xs, ys = case
    rng = np.random.default_rng(12)
    seg, start = sort_into_cells(chains_and_strays(rng, width, height, np.array([xs[3], ys[2]])), lattice)
    assert (seg.p[1:] == seg.q[:-1]).all(axis=1).mean() > 0.5  # the shared-end-point path is exercised
    got = near_field_grid(xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    expected = near_sum_on_grid(xs, ys, lattice, start, seg)
    assert got.shape == (len(ys), len(xs), 3)
    assert np.abs(expected).max() > 0.1
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("row_samples", [0, 10**9], ids=["columns", "rows"])
def test_near_field_grid_equals_the_numpy_reference_over_each_block(row_samples, monkeypatch):
    monkeypatch.setattr(grid, "ROW_SAMPLES", row_samples)
    rng = np.random.default_rng(13)
    lattice = Lattice(3, 64.0)
    xs, ys = np.arange(0.0, 64.5, 4.0), np.sort(rng.uniform(0.0, 64.0, 13))
    seg, start = sort_into_cells(chains_and_strays(rng, 64, 64, np.array([xs[5], ys[4]])), lattice)
    got = near_field_grid(xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    seg_cells = lattice.cell_of(seg.midpoints)
    for row, y in enumerate(ys):
        for column, x in enumerate(xs):
            near = np.abs(seg_cells - lattice.cell_of(np.array([[x, y]]))[0]).max(axis=1) <= 1
            expected = direct_sum_reference(
                np.array([[x, y]]), seg.p[near], seg.q[near], seg.flux[near], seg.jump[near]
            )
            np.testing.assert_allclose(got[row, column], expected[0], rtol=0, atol=1e-9)


def test_near_field_grid_adds_into_out_and_handles_empty_input():
    rng = np.random.default_rng(14)
    lattice = Lattice(3, 64.0)
    xs, ys = np.arange(0.5, 64, 3.0), np.arange(0.25, 64, 5.0)
    seg, start = sort_into_cells(chains_and_strays(rng, 64, 64, np.array([xs[0], ys[0]])), lattice)
    args = (lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    alone = near_field_grid(xs, ys, *args)
    base = rng.normal(size=alone.shape)
    out = base.copy()
    assert near_field_grid(xs, ys, *args, out=out) is out
    np.testing.assert_allclose(out, base + alone, rtol=0, atol=1e-12)
    assert near_field_grid(xs[:0], ys, *args).shape == (len(ys), 0, 3)
    empty = np.zeros(lattice.cells_per_side**2 + 1, np.int64)
    nothing = np.zeros((0, 2))
    assert not near_field_grid(xs, ys, lattice.cells_per_side, lattice.cell_size, empty,
                               nothing, nothing, np.zeros((0, 3)), np.zeros((0, 3))).any()
    with pytest.raises(ValueError, match="sorted"):
        near_field_grid(xs[::-1], ys, *args)


def test_far_field_grid_equals_the_numpy_far_field():
    rng = np.random.default_rng(15)
    n, order = 8, 6
    poly = rng.normal(size=(n, n, 3, order + 1, order + 1))
    for xs, ys in [(np.arange(0.0, 64.5, 2.0), np.arange(0.0, 64.5, 4.0)),
                   (np.sort(rng.uniform(19.0, 45.0, 23)), np.sort(rng.uniform(3.0, 30.0, 17))),
                   (sample_coordinates(37, 64, 3), sample_coordinates(23, 40, 3))]:
        got = far_field_grid(poly, xs, ys, 8.0)
        np.testing.assert_allclose(got, far_field_reference(poly, xs, ys, 8.0), rtol=1e-12, atol=1e-12)


@numba.njit
def _logs(x):
    out = np.empty_like(x)
    for i in range(len(x)):
        out[i] = log_poly(x[i])
    return out


@numba.njit
def _atan2s(y, x):
    out = np.empty_like(x)
    for i in range(len(x)):
        out[i] = atan2_poly(y[i], x[i])
    return out


def test_elementary_functions_are_accurate_to_a_few_ulp():
    rng = np.random.default_rng(16)
    x = np.concatenate([np.exp(rng.uniform(-690, 700, 20000)), rng.uniform(0.5, 2.0, 20000),
                        [1e-300, 1.0, 2.0, 0.5, np.sqrt(0.5), np.sqrt(2.0),
                         np.nextafter(1.0, 0), np.nextafter(1.0, 2)]])
    expected = np.array([math.log(v) for v in x])
    assert (np.abs(_logs(x) - expected) <= np.spacing(np.abs(expected)) + 1e-300).all()
    y = rng.normal(size=40000) * np.exp(rng.uniform(-20, 20, 40000))
    x = rng.normal(size=40000) * np.exp(rng.uniform(-20, 20, 40000))
    special = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (1.0, 1.0), (-1.0, -1.0), (3.0, -3.0),
               (1e-300, -1.0), (-1e-300, -1.0), (2.0, 0.66 * 3.0), (1.0, 1.0 / 0.66)]
    y = np.concatenate([y, [s[0] for s in special]])
    x = np.concatenate([x, [s[1] for s in special]])
    expected = np.array([math.atan2(a, b) for a, b in zip(y, x)])
    assert (np.abs(_atan2s(y, x) - expected) <= 2 * np.spacing(np.abs(expected)) + 1e-300).all()


@pytest.fixture(scope="module")
def small_rep():
    """A built 128 x 80 document: two circles and a chain, with colour gradients."""
    rng = np.random.default_rng(17)
    stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 1.0, 2.0))
    curves = (
        DiffusionCurve(circle_points(40, 40, 25), left=stops, right=stops[::-1]),
        DiffusionCurve(circle_points(95, 35, 18), left=stops[::-1], right=stops),
        DiffusionCurve(straight_chain([(10, 70), (60, 62), (120, 75)]), left=stops, right=stops),
    )
    return build(Document(128, 80, curves), Settings(levels=4))


def old_rasterise(rep, width, height, samples):
    """The previous path: far field by numpy (at the degrees the samples' places need), near field by ``near_sum``
    at every sample."""
    xs, ys = sample_coordinates(width, rep.width, samples), sample_coordinates(height, rep.height, samples)
    lattice, seg = rep.lattice, rep.segments
    far = local_field_reference(rep.local, rep.order, xs, ys, lattice.cell_size, sample_degrees(rep.order))
    values = far + near_sum_on_grid(xs, ys, lattice, rep.cell_start, seg)
    return values.reshape(height, samples, width, samples, 3).mean(axis=(1, 3))


@pytest.mark.parametrize(
    "width, height, samples", [(128, 80, 1), (128, 80, 3), (37, 23, 1), (37, 23, 3), (300, 190, 1)]
)
def test_rasterise_equals_far_plus_near_sum(small_rep, monkeypatch, width, height, samples):
    monkeypatch.setattr(raster, "SUB_CELL_SAMPLES", 10**9)  # the exact near field (test_raster_subcells: the split)
    monkeypatch.setattr(raster, "NEAR_PRECISION", "double")  # in float64 (test_raster_subcells: the float32 bound)
    image = rasterise(small_rep, width, height, samples=samples)
    expected = old_rasterise(small_rep, width, height, samples)
    assert image.shape == (height, width, 3)
    assert np.ptp(expected) > 0.3
    np.testing.assert_allclose(image, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("samples", [1, 3])
def test_bands_do_not_change_the_image(small_rep, monkeypatch, samples):
    whole = rasterise(small_rep, 150, 97, samples=samples)
    # bands of 6 rows (samples=1) or 1 row (samples=3), cutting cells
    monkeypatch.setattr(raster, "BAND_SAMPLES", 1000)
    banded = rasterise(small_rep, 150, 97, samples=samples)
    np.testing.assert_allclose(banded, whole, rtol=0, atol=1e-12)


def test_rasterising_makes_no_tensor_of_the_representation():
    """With four fine cells a pixel (L 8 under a 128 x 80 image) the local expansions (3 x 9 complex terms a
    cell) are 70x the image.  The raster reads them in place: besides the image, numpy allocates at most
    per-cell bookkeeping (cell counts), under a twentieth of the expansions; a polynomial tensor of the
    cells (the 9 x 9 real coefficients of the old far field) would be 1.5x them."""
    rng = np.random.default_rng(5)
    stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 1.0))
    curves = (DiffusionCurve(circle_points(128, 80, 60), left=stops, right=stops[::-1]),)
    rep = build(Document(256, 160, curves), Settings(levels=8))
    rasterise(rep, 128, 80, samples=1)  # compiled before measuring
    tracemalloc.start()
    try:
        image = rasterise(rep, 128, 80, samples=1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert rep.local.nbytes > 50 * image.nbytes
    assert peak - image.nbytes < rep.local.nbytes / 20
