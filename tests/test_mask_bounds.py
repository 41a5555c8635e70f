"""Bounds on a field's value over each cell (``value_bounds``), and the raster leaving out the cells of a mask
whose bounds settle its layer's weight (``composite.settled``, ``raster._mask_values``).

Left out, such a cell's mask values are its centre's luminance, which give every layer the weight the mask's own
values would: the picture is the same to the bit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from layered import SIZE, sharp_mask, soft_mask, three_layers
from shapes import scattered_document
from test_points_render import random_points

from fmr_editor.engine import LiveStack, Representation, build, evaluate_points, raster, rasterise
from fmr_editor.engine.blending import layer_weights
from fmr_editor.engine.composite import FIRST_CHANNEL, NEGLIGIBLE_WEIGHT, LayerFields, settled
from fmr_editor.engine.points.field import PointField
from fmr_editor.model import DiffusionPoint, Document, Mask
from fmr_editor.model.layer import MASK_LUMA


@pytest.fixture(scope="module")
def reps():
    """A curve mask (1 inside a circle, 0 outside), curves of many colours, and those with points near and far."""
    curves = scattered_document(96, seed=4)
    return {"sharp mask": build(Document(SIZE, SIZE, sharp_mask().curves)), "curves": build(curves),
            "curves and points": build(Document(96, 96, curves.curves,
                                                points=random_points(60, 96, seed=5, radii=(0.7, 40.0))))}


@pytest.mark.parametrize("name", ["sharp mask", "curves", "curves and points"])
@pytest.mark.parametrize("weights", [MASK_LUMA, FIRST_CHANNEL], ids=["luminance", "first channel"])
def test_every_point_of_a_cell_lies_within_its_bounds(reps, name, weights):
    rep = reps[name]
    centre, spread = rep.scalar_bounds(weights)
    rng = np.random.default_rng(7)
    size, n = rep.lattice.cell_size, rep.lattice.cells_per_side
    cells = rng.integers(0, n, (4000, 2))
    corners = rng.integers(0, 2, (4000, 2)) * (1 - 1e-9)  # cell corners too: the farthest from the centre
    offsets = np.where(rng.random((4000, 1)) < 0.3, corners, rng.random((4000, 2)))
    points = (cells[:, ::-1] + offsets) * size
    values = evaluate_points(rep, points) @ weights
    moved = np.abs(values - centre[cells[:, 0], cells[:, 1]])
    assert (moved <= spread[cells[:, 0], cells[:, 1]] + 1e-12).all()
    assert np.ptp(values) > 0.5
    if name == "sharp mask":  # tight where the mask is flat: most of it
        assert np.mean(spread < 1e-5) > 0.5


@pytest.mark.parametrize("name", ["sharp mask", "curves and points"])
@pytest.mark.parametrize("per_pixel", [1, 3, 6])  # one cell of 8-12 px: no split, 2 and 4 sub-cells a side
def test_the_rasters_samples_lie_within_their_cells_bounds(reps, name, per_pixel):
    """What the raster computes (float32 near field where its bound allows, sub-cells' series) stays within the
    bounds, which count those errors too."""
    rep = reps[name]
    centre, spread = rep.scalar_bounds(MASK_LUMA)
    values = rasterise(rep, samples=per_pixel) @ MASK_LUMA  # each pixel's mean of its samples: within the bounds
    n, size = rep.lattice.cells_per_side, rep.lattice.cell_size
    cell = np.minimum(np.arange(rep.width) // size, n - 1).astype(int)  # every sample of a pixel in its cell
    moved = np.abs(values - centre[cell][:, cell])
    assert (moved <= spread[cell][:, cell] + 1e-9).all()
    assert np.ptp(values) > 0.5


LAYERS = {"plain": dict(mask_base=0.0), "opacity": dict(mask_base=0.0, opacity=0.7),
          "inverted": dict(mask_base=0.0, mask_inverted=True), "base": dict(mask_base=0.3, opacity=0.9),
          "alpha": dict(mask_base=0.0, alpha="alpha"),
          "alpha, inverted": dict(mask_base=0.0, alpha="alpha", mask_inverted=True, opacity=0.5)}


@pytest.mark.parametrize("settings", sorted(LAYERS))
def test_a_settled_cell_gives_one_weight_to_every_luminance_in_its_bounds(settings):
    layer = LayerFields("image", mask="mask", **LAYERS[settings])
    rng = np.random.default_rng(len(settings))
    centre = rng.choice([0.0, 1.0, 0.5, -0.5, 1.3], 2000) + rng.normal(0, 1e-5, 2000)
    spread = 10.0 ** rng.uniform(-9, -2, 2000)
    ends = settled(layer, centre, spread)
    assert 0.2 < ends.mean() < 0.95
    alpha = rng.uniform(0, 1, (2000 * 7, 1))

    def weights(luminance: np.ndarray) -> np.ndarray:  # as the raster's compiled pass weighs a sample
        out = np.empty(len(alpha))
        layer_weights(out, np.repeat(luminance, 7)[:, None], MASK_LUMA, float(layer.mask_base), True,
                      layer.mask_inverted, NEGLIGIBLE_WEIGHT, alpha if layer.alpha is not None else np.zeros((0, 3)),
                      0, float(layer.opacity))
        return out.reshape(2000, 7)

    at_centre = weights(centre)
    for t in np.linspace(-1, 1, 7):  # across each cell's range, at any alpha: the centre's weight
        assert np.array_equal(weights(centre + t * spread)[ends], at_centre[ends])
    # and what is plainly settled is: a mask's value surely below 0
    top = 1 - layer.mask_base - (centre - spread) if layer.mask_inverted else layer.mask_base + centre + spread
    assert ends[top < -NEGLIGIBLE_WEIGHT].all() and (top < -NEGLIGIBLE_WEIGHT).any()


@pytest.fixture(scope="module")
def masked():
    """``three_layers`` (a soft mask at 0.7 opacity, a sharp one under a hue rotation), and variants: the sharp
    mask inverted over a base, and shared by a translucent layer (an alpha of points)."""
    picture = LiveStack(three_layers()).composite
    bottom, middle, top = picture.shown
    alpha = build(Document(SIZE, SIZE, points=soft_mask(9).points))
    return {"three layers": picture,
            "inverted, base": replace(picture, layers=(bottom, middle, replace(top, mask_inverted=True,
                                                                              mask_base=0.2))),
            "shared, alpha": replace(picture, layers=(bottom, replace(middle, mask=top.mask, alpha=alpha), top))}


@pytest.mark.parametrize("name", ["three layers", "inverted, base", "shared, alpha"])
@pytest.mark.parametrize("precision, samples", [("double", 2), ("single", 2), ("single", 4)])  # 4: sub-cells
def test_a_mask_left_out_where_its_bounds_settle_the_weight_gives_the_same_picture(masked, name, precision,
                                                                                   samples, monkeypatch):
    picture = masked[name]
    monkeypatch.setattr(raster, "NEAR_PRECISION", precision)
    skipped, evaluate = [], raster._fmr_samples

    def counted(rep, *args):
        skip = args[6] if len(args) > 6 else None
        if rep is picture.shown[2].mask:
            skipped.append(0 if skip is None else int(skip.sum()))
        return evaluate(rep, *args)

    monkeypatch.setattr(raster, "_fmr_samples", counted)
    bounded = rasterise(picture, 120, samples=samples, coverage=True)
    cells = picture.shown[2].mask.lattice.cells_per_side ** 2
    assert len(skipped) == 1  # evaluated once, for both layers of "shared"
    assert skipped[0] > (cells / 2 if name != "inverted, base" else 0)  # there 0.8 outside: not settled
    original = raster._composed
    monkeypatch.setattr(raster, "_composed", lambda *args, **kwargs: original(*args, **dict(kwargs, bounded=False)))
    np.testing.assert_array_equal(bounded, rasterise(picture, 120, samples=samples, coverage=True))


def test_a_sparse_raster_makes_no_bounds(masked, monkeypatch):
    """Below ``BOUNDED_SAMPLES`` samples a cell of a mask, its bounds would cost about what they save: not made."""
    picture = masked["three layers"]
    made, scalar_bounds = [], Representation.scalar_bounds
    monkeypatch.setattr(Representation, "scalar_bounds", lambda rep, weights: made.append(rep) or scalar_bounds(
        rep, weights))
    cell = picture.shown[2].mask.lattice.cell_size
    sparse = int(picture.width * np.sqrt(raster.BOUNDED_SAMPLES - 1) / cell)  # pixels a side: just below
    rasterise(picture, sparse, samples=1)
    assert made == []
    rasterise(picture, sparse + 2, samples=1)
    assert picture.shown[2].mask in made


def test_a_soft_mask_painted_in_a_corner_is_evaluated_there_alone(monkeypatch):
    """Points alone, in the top left quarter, over base 0: the rest of the mask is 0 to its bounds, settled, and
    left out (``_scalar_points``' skip), the picture the same to the bit."""
    document = three_layers()
    bottom, middle, _ = document.layers
    rng = np.random.default_rng(12)
    dabs = [DiffusionPoint(tuple(rng.uniform(8, 40, 2)), rng.uniform(4, 8), (1.0, 1.0, 1.0), 0.9) for _ in range(8)]
    picture = LiveStack(replace(document, layers=(bottom, replace(middle, mask=Mask(points=dabs))))).composite
    skips, add_grid = [], PointField.add_grid
    monkeypatch.setattr(PointField, "add_grid", lambda field, *args: skips.append(args[-1]) or add_grid(field, *args))
    bounded = rasterise(picture, 128, samples=2)
    assert len(skips) == 1 and 0.5 < skips[0].mean() < 1  # most of it settled, the dabs not
    original = raster._composed
    monkeypatch.setattr(raster, "_composed", lambda *args, **kwargs: original(*args, **dict(kwargs, bounded=False)))
    np.testing.assert_array_equal(bounded, rasterise(picture, 128, samples=2))
    assert skips[-1] is None
