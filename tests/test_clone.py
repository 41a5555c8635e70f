"""Exact seamless cloning (``engine.solve.clone``) against an independent raster oracle.

The oracle is Perez et al.'s discrete Poisson clone: a 5-point finite-difference solve (scipy) on a grid of
half a pixel, with the guidance ``g`` sampled exactly at the grid points from the source (random access) and
the target ``f_t`` around the region.  The clone layer's field, evaluated by the direct sum, must match it
inside the region (3 px from the boundary: mean <= 1/255, p99 <= 4/255) and be 0 outside.  The paper's
approximation (C = f_t - g on the boundary, E = 0, no solve) is computed as a contrast and printed.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse
import scipy.sparse.linalg
import shapely
from shapes import scattered_document

from fmr_editor.engine import Composite, LiveStack, build, evaluate_points
from fmr_editor.engine.cloning import clone_layer, placed_points
from fmr_editor.engine.geometry.segments import Segments, empty_segments
from fmr_editor.engine.kernels.segment_sums import direct_sum
from fmr_editor.engine.solve.clone import SeamlessClone, Similarity, boundary, clipped_to, paper_segments
from fmr_editor.model import DiffusionPoint, EditRefused

SIZE = 128
STEP = 0.5  # the oracle's grid, pixels
LEVEL = 1 / 255


@pytest.fixture(scope="module")
def images():
    return build(scattered_document(SIZE, seed=3)), build(scattered_document(SIZE, seed=8))


def hexagon(cx: float, cy: float, rx: float, ry: float) -> np.ndarray:
    angles = np.linspace(0, 2 * np.pi, 7)[:-1] + 0.2
    return np.stack([cx + rx * np.cos(angles), cy + ry * np.sin(angles)], axis=1)


def about_centre(region: np.ndarray, scale: float, degrees: float, offset) -> Similarity:
    """Rotate and scale about the region's centroid, then move by ``offset`` (the CLI's convention)."""
    centre = region.mean(axis=0)
    turned = Similarity(scale, degrees)
    return Similarity(scale, degrees, tuple(centre - turned.apply(centre[None])[0] + np.asarray(offset)))


def oracle(inside: np.ndarray, guide: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The discrete Poisson clone at the ``inside`` grid points: ``4u_i - sum u_j = sum (g_i - g_j)`` with
    ``u_j = f_t`` at neighbours outside."""
    index = -np.ones(inside.shape, int)
    index[inside] = np.arange(inside.sum())
    rows, columns = np.nonzero(inside)
    own = index[inside]
    entries = [(own, own, np.full(len(own), 4.0))]
    rhs = np.zeros((len(own), 3))
    for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        r, c = rows + dr, columns + dc
        rhs += guide[rows, columns] - guide[r, c]
        within = inside[r, c]
        entries.append((own[within], index[r, c][within], -np.ones(within.sum())))
        rhs[~within] += target[r, c][~within]
    i, j, v = (np.concatenate(parts) for parts in zip(*entries))
    matrix = scipy.sparse.csc_matrix((v, (i, j)), shape=(len(own), len(own)))
    return scipy.sparse.linalg.splu(matrix).solve(rhs)


def oracle_grid(source, target, clone: SeamlessClone):
    """The oracle on a grid of ``STEP`` over the clone's region: the grid's points, which lie inside, the
    guide ``g`` and target there, the oracle's values inside and each point's distance to the boundary."""
    region = shapely.Polygon(clone.region)
    x0, y0, x1, y1 = region.bounds
    xs = np.arange(np.floor(x0) - 2, np.ceil(x1) + 2, STEP)
    ys = np.arange(np.floor(y0) - 2, np.ceil(y1) + 2, STEP)
    grid = np.stack(np.meshgrid(xs, ys), axis=-1)
    points = grid.reshape(-1, 2)
    inside = shapely.contains_xy(region, points[:, 0], points[:, 1]).reshape(grid.shape[:2])
    guide = evaluate_points(source, clone.similarity.inverse(points)).reshape(grid.shape[:2] + (3,))
    fields = evaluate_points(target, points).reshape(grid.shape[:2] + (3,))
    distance = shapely.distance(shapely.LinearRing(clone.region), shapely.points(points))
    return points, inside, guide, fields, oracle(inside, guide, fields), distance


def errors(source, target, clone: SeamlessClone) -> dict[str, float]:
    """Ours and the paper's against the oracle, in 8-bit levels; and the largest value of ours outside."""
    target_at_gamma = evaluate_points(target, clone.midpoints)
    layer = clone.segments(target_at_gamma)
    points, inside, guide, fields, expected, distance = oracle_grid(source, target, clone)
    far_in = (distance >= 3)[inside.ravel()]
    ours = direct_sum(points[inside.ravel()], layer.p, layer.q, layer.flux, layer.jump)
    off = np.abs(ours - expected)[far_in] / LEVEL
    paper = paper_segments(clone, target_at_gamma, evaluate_points(source, clone.similarity.inverse(clone.midpoints)))
    theirs = guide[inside] + direct_sum(points[inside.ravel()], paper.p, paper.q, paper.flux, paper.jump)
    paper_off = np.abs(theirs - expected)[far_in] / LEVEL
    far_out = (distance >= 3) & ~inside.ravel()
    outside = direct_sum(points[far_out], layer.p, layer.q, layer.flux, layer.jump)
    result = {"mean": off.mean(), "p99": np.percentile(off, 99), "outside": np.abs(outside).max() / LEVEL,
              "paper mean": paper_off.mean(), "paper p99": np.percentile(paper_off, 99)}
    print({key: round(float(value), 3) for key, value in result.items()})
    return result


@pytest.mark.parametrize("region, similarity", [
    (hexagon(60, 62, 30, 26), Similarity(offset=(8.0, -6.0))),  # a translation
    (hexagon(60, 62, 30, 26), None),  # rotated by 30 degrees and scaled by 1.3 about its centre
    (hexagon(45, 80, 34, 30), Similarity(offset=(30.0, -20.0))),  # across other curves of both images
])
def test_the_clone_is_the_raster_poisson_clone(images, region, similarity):
    source, target = images
    similarity = similarity or about_centre(region, 1.3, 30.0, (4.0, 3.0))
    clone = SeamlessClone(source.segments, region, similarity)
    assert np.any(~clone.copied.on_border)  # source curves inside the region, cut at its boundary
    curves = target.segments.take(~target.segments.on_border)
    lines = shapely.linestrings(np.stack([curves.p, curves.q], axis=1))
    assert shapely.intersects(shapely.LinearRing(clone.region), lines).any()  # target curves cross the boundary
    found = errors(source, target, clone)
    assert found["mean"] <= 1.0 and found["p99"] <= 4.0
    assert found["outside"] <= 0.5  # the layer is 0 outside its region
    assert found["paper mean"] > 3 * found["mean"]  # the approximation is visibly worse


def test_a_region_cloned_within_one_image(images):
    source, _ = images
    clone = SeamlessClone(source.segments, hexagon(40, 40, 22, 22), Similarity(offset=(50.0, 45.0)))
    found = errors(source, source, clone)
    assert found["mean"] <= 1.0 and found["p99"] <= 4.0 and found["outside"] <= 0.5


def test_moving_a_clone_keeps_its_factorisation_and_gives_the_clone_built_there(images):
    source, target = images
    region = hexagon(60, 62, 30, 26)
    clone = SeamlessClone(source.segments, region, Similarity(offset=(2.0, 1.0)))
    moved = clone.moved(6.0, -7.0)
    fresh = SeamlessClone(source.segments, region, Similarity(offset=(8.0, -6.0)))
    assert moved._factors is clone._factors
    a = moved.segments(evaluate_points(target, moved.midpoints))
    b = fresh.segments(evaluate_points(target, fresh.midpoints))
    np.testing.assert_allclose(a.p, b.p, atol=1e-9)
    np.testing.assert_allclose(a.flux, b.flux, atol=1e-7)


def test_a_constant_target_gives_the_indicator_of_the_region():
    region = hexagon(60, 62, 28, 24)
    clone = SeamlessClone(empty_segments(), region)
    layer = clone.segments(np.ones((len(clone.midpoints), 3)))
    values = direct_sum(np.array([[60.0, 62.0], [70.0, 55.0], [200.0, 200.0], [60.0, 90.0]]),
                        layer.p, layer.q, layer.flux, layer.jump)
    np.testing.assert_allclose(values[:, 0], [1.0, 1.0, 0.0, 0.0], atol=1e-12)
    assert np.abs(layer.flux).max() < 1e-10  # a pure double layer: nothing to solve


def test_clipping_keeps_exactly_the_parts_inside_and_the_boundary_turns_the_inside_left():
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    colours = np.arange(9.0).reshape(3, 3)
    starts, ends = np.array([[-5.0, 5.0], [2.0, 2.0], [20.0, 20.0]]), np.array([[15.0, 5.0], [3.0, 3.0], [30.0, 30.0]])
    crossing = Segments(starts, ends, colours, colours, np.zeros(3, bool), -colours)
    inside = clipped_to(crossing, square)
    np.testing.assert_allclose(inside.p, [[0.0, 5.0], [2.0, 2.0]])
    np.testing.assert_allclose(inside.q, [[10.0, 5.0], [3.0, 3.0]])
    np.testing.assert_array_equal(inside.jump, colours[:2])  # each piece keeps its segment's C and E
    p, q = boundary(square, 1.0)
    tangent = (q - p) / np.hypot(*(q - p).T)[:, None]
    left = 0.5 * (p + q) + 0.01 * np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    assert len(p) == 40 and shapely.contains_xy(shapely.Polygon(square), left[:, 0], left[:, 1]).all()


@pytest.mark.parametrize("region", [np.zeros((2, 2)), np.array([[0, 0], [10, 10], [10, 0], [0, 10.0]])])
def test_a_region_that_is_no_simple_polygon_is_refused(region):
    with pytest.raises(EditRefused, match="three finite|simple polygon"):
        SeamlessClone(empty_segments(), region)


# -- the clone as a layer of a composite ---------------------------------------------------------------------------


def layered_errors(source, below, clone: SeamlessClone) -> dict[str, float]:
    """The composite with the clone layer on top against the oracle inside, the target outside, and the step
    across the boundary, in 8-bit levels."""
    points = source.points.source if source.points is not None else ()
    picture = Composite(below.width, below.height, below.layers + (clone_layer(clone, below, points=points),))
    points, inside, _, fields, expected, distance = oracle_grid(source, below, clone)
    expected, fields = np.clip(expected, 0, 1), np.clip(fields, 0, 1)  # a layer shows its colours clamped
    shown = evaluate_points(picture, points)
    on_canvas = ((points >= 0) & (points <= [below.width, below.height])).all(axis=1)
    far_in = (distance >= 3)[inside.ravel()]
    off = np.abs(shown[inside.ravel()] - expected)[far_in] / LEVEL
    out = ~inside.ravel() & (distance >= 1) & on_canvas
    mids, normal = clone.midpoints, np.stack([clone.gamma_q[:, 1] - clone.gamma_p[:, 1],
                                              clone.gamma_p[:, 0] - clone.gamma_q[:, 0]], axis=1)
    normal /= np.hypot(*normal.T)[:, None]
    sides = [mids + 0.25 * normal, mids - 0.25 * normal]
    seam = np.all([((side > 0) & (side < [below.width, below.height])).all(axis=1) for side in sides], axis=0)
    step = np.abs(evaluate_points(picture, sides[0][seam]) - evaluate_points(picture, sides[1][seam]))  # not along
    # the canvas edge, where the clone meets the outside of the canvas
    result = {"mean": off.mean(), "p99": np.percentile(off, 99),
              "outside": np.abs(shown[out] - fields.reshape(-1, 3)[out]).max() / LEVEL,
              "step median": np.median(step) / LEVEL}
    print({key: round(float(value), 3) for key, value in result.items()})
    return result


@pytest.fixture(scope="module")
def below():
    return LiveStack(scattered_document(SIZE, seed=8)).composite


@pytest.mark.parametrize("region, similarity", [
    (hexagon(60, 62, 30, 26), Similarity(offset=(8.0, -6.0))),
    (hexagon(60, 62, 30, 26), None),
    (hexagon(60, 40, 30, 26), Similarity(offset=(50.0, -30.0))),  # over the canvas's top and right edges
])
def test_the_clone_layer_composed_over_the_target_is_the_poisson_clone(images, below, region, similarity):
    source, _ = images
    similarity = similarity or about_centre(region, 1.3, 30.0, (4.0, 3.0))
    clone = SeamlessClone(source.segments, region, similarity, canvas=(below.width, below.height))
    found = layered_errors(source, below, clone)
    assert found["mean"] <= 1.0 and found["p99"] <= 4.0
    assert found["outside"] <= 0.5  # the target, untouched
    assert found["step median"] <= 1.0  # no seam


def test_a_source_with_diffusion_points_clones_them_too(below):
    rng = np.random.default_rng(9)
    dabs = [DiffusionPoint(tuple(rng.uniform(30, 95, 2)), float(rng.uniform(2, 14)), tuple(rng.random(3)), 0.7)
            for _ in range(12)]
    source = build(scattered_document(SIZE, seed=3).with_points(dabs))
    clone = SeamlessClone(source.segments, hexagon(60, 62, 30, 26), about_centre(hexagon(60, 62, 30, 26), 1.2, -20.0,
                          (3.0, -4.0)), canvas=(below.width, below.height))
    assert len(placed_points(source.points.source, clone)) >= 6  # copied: inside, and reaching in from outside
    found = layered_errors(source, below, clone)
    assert found["mean"] <= 1.0 and found["p99"] <= 4.0 and found["outside"] <= 0.5 and found["step median"] <= 1.0


def test_a_region_off_the_canvas_is_refused(images):
    source, _ = images
    with pytest.raises(EditRefused, match="wholly outside"):
        SeamlessClone(source.segments, hexagon(60, 62, 20, 20), Similarity(offset=(300.0, 0.0)), canvas=(SIZE, SIZE))


def test_the_compiled_pair_matrices_equal_the_numpy_reference():
    from fmr_editor.engine.kernels.potentials import pair_integrals
    from fmr_editor.engine.kernels.segment_sums import pair_matrices

    rng = np.random.default_rng(4)
    p, q, targets = rng.uniform(0, 20, (7, 2)), rng.uniform(0, 20, (7, 2)), rng.uniform(-5, 25, (30, 2))
    for ours, reference in zip(pair_matrices(targets, p, q), pair_integrals(targets, p, q)):
        np.testing.assert_allclose(ours, reference, rtol=1e-12, atol=1e-12)


def test_pair_matrices_write_s_into_a_larger_system_where_it_lies():
    from fmr_editor.engine.kernels.segment_sums import pair_matrices

    rng = np.random.default_rng(5)
    p, q, targets = rng.uniform(0, 20, (7, 2)), rng.uniform(0, 20, (7, 2)), rng.uniform(-5, 25, (30, 2))
    system = np.full((31, 8), 7.0)
    single, double = pair_matrices(targets, p, q, single=system[:30])
    alone = pair_matrices(targets, p, q)
    assert np.shares_memory(single, system)
    np.testing.assert_array_equal(system[:30, :7], alone[0])
    np.testing.assert_array_equal(double, alone[1])
    assert (system[:, 7] == 7.0).all() and (system[30] == 7.0).all()  # the rest as it was
    for wrong in (system[:30, :6], system[:29], system[:30].astype(np.float32), np.asfortranarray(system[:30])):
        with pytest.raises(ValueError, match="C-contiguous float64"):
            pair_matrices(targets, p, q, single=wrong)


def test_a_second_clone_over_the_first_blends_into_the_picture_with_it(images, below):
    source, _ = images
    first = SeamlessClone(source.segments, hexagon(60, 62, 30, 26), Similarity(offset=(-10.0, 0.0)),
                          canvas=(below.width, below.height))
    with_first = Composite(below.width, below.height, below.layers + (clone_layer(first, below, layer_id=1),))
    second = SeamlessClone(source.segments, hexagon(40, 40, 22, 22), Similarity(offset=(45.0, 30.0)),
                           canvas=(below.width, below.height))
    assert shapely.Polygon(first.region).intersects(shapely.Polygon(second.region))  # they overlap
    found = layered_errors(source, with_first, second)  # the oracle's target is the picture with the first clone
    assert found["mean"] <= 1.0 and found["p99"] <= 4.0 and found["outside"] <= 0.5 and found["step median"] <= 1.0
