"""Documents with diffusion points: the FMR raster against the direct Gaussian and boundary sums."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.engine import build, evaluate_points, rasterise
from fmr_editor.engine.raster import sample_coordinates
from fmr_editor.model import DiffusionPoint, Document

HALF_LEVEL = 0.5 / 255


def random_points(count: int, size: float, seed: int, radii=(0.5, 200.0)) -> list[DiffusionPoint]:
    rng = np.random.default_rng(seed)
    radius = np.exp(rng.uniform(np.log(radii[0]), np.log(radii[1]), count))
    return [DiffusionPoint(tuple(rng.uniform(-0.1 * size, 1.1 * size, 2)), float(r), tuple(rng.random(3)),
                           float(rng.choice([-1.0, 1.0]) * rng.uniform(0.2, 1.0)))
            for r in radius]


@pytest.fixture(scope="module")
def points_only():
    doc = Document(256, 256, points=random_points(300, 256, seed=1))
    return build(doc)


def test_points_alone_match_the_direct_gaussian_sum(points_only):
    fmr = rasterise(points_only, 128, 128, samples=1)
    direct = rasterise(points_only, 128, 128, samples=1, method="direct")
    assert np.abs(fmr - direct).max() <= HALF_LEVEL
    assert np.abs(direct).max() > 0.5  # the points are there


def test_both_kinds_of_point_are_used(points_only):
    near, tensor = points_only.points.near, points_only.points.tensor
    assert 0 < len(near) < len(points_only.points.points)
    assert np.abs(tensor).max() > 0


def test_a_field_of_points_alone_sums_no_segment(points_only):
    """Its canvas border solves to 0: ``near`` leaves it out, and the raster matches the direct sums over every
    segment (above)."""
    seg = points_only.segments
    assert len(seg.p) > 0 and not seg.flux.any() and not seg.jump.any()
    near, cell_start = points_only.near
    assert len(near.p) == 0 and len(cell_start) == len(points_only.cell_start) and not cell_start.any()
    curves = build(scattered_document(64, circles=1, seed=3))
    assert curves.near[0] is curves.segments and curves.near[1] is curves.cell_start


def test_curves_and_points_together_match_the_direct_sums():
    doc = scattered_document(128, circles=3, seed=4).with_points(random_points(60, 128, seed=2, radii=(0.5, 60.0)))
    rep = build(doc)
    fmr = rasterise(rep, 128, 128, samples=1)
    direct = rasterise(rep, 128, 128, samples=1, method="direct")
    assert np.abs(fmr - direct).max() <= HALF_LEVEL
    curves_only = rasterise(build(doc.with_points(())), 128, 128, samples=1)
    assert np.abs(fmr - curves_only).max() > 0.05  # the points changed the image


def test_evaluate_points_agrees_with_the_raster(points_only):
    image = rasterise(points_only, 64, 64, samples=1)
    xs, ys = sample_coordinates(64, 256, 1), sample_coordinates(64, 256, 1)
    rows = np.array([0, 7, 31, 63])
    cols = np.array([5, 20, 40, 63])
    values = evaluate_points(points_only, np.stack([xs[cols], ys[rows]], axis=1))
    np.testing.assert_allclose(values, image[rows, cols], rtol=0, atol=1e-9)


def test_documents_check_their_points():
    with pytest.raises(TypeError, match="DiffusionPoint"):
        Document(16, 16, points=[(1.0, 2.0)])
    doc = Document(16, 16).with_points([DiffusionPoint((1, 2), 3.0, (1, 0, 0))])
    assert doc.points[0].radius == 3.0 and doc.curves == ()


def test_the_work_per_pixel_does_not_grow_with_the_number_of_points():
    """Figure 10 of the paper, structurally: more points, same lattice and no exact near points.

    Pixels then cost one cell polynomial each whatever the count (bench/bench_points.py times it).
    """
    rng = np.random.default_rng(3)
    shapes = set()
    for count in (1_000, 10_000, 100_000):
        radii = np.exp(rng.uniform(np.log(12), np.log(96), count))
        points = [DiffusionPoint(tuple(xy), r, (0.5, 0.5, 0.5), 0.01)
                  for xy, r in zip(rng.uniform(0, 1024, (count, 2)), radii)]
        rep = build(Document(1024, 1024, points=points))
        assert len(rep.points.near) == 0
        shapes.add(rep.polynomials().shape)
    assert len(shapes) == 1
