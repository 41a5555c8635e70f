"""Soft masks (diffusion points alone) rasterised in the one channel they are read through, against their colour.

A mask is read through its luminance and an alpha field through its first channel (``composite.scalar_reads``);
where such a field has no segments, the raster evaluates that one channel: each cell's polynomial of
``w . colour`` and the near points' weights ``w . colour``.  Those are the colour's values dotted with ``w`` in
another order of the same sums, so they agree to rounding.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from layered import SIZE, soft_mask, three_layers
from test_points_render import random_points

from fmr_editor.engine import LiveStack, build, raster, rasterise
from fmr_editor.engine.composite import FIRST_CHANNEL, Composite, LayerFields, compose, compose_reference, scalar_reads
from fmr_editor.engine.kernels.grid import far_field_grid
from fmr_editor.engine.points.field import PointField
from fmr_editor.engine.points.near import near_grid
from fmr_editor.engine.raster import far_field_reference, sample_coordinates
from fmr_editor.model import Document
from fmr_editor.model.layer import MASK_LUMA

#: Sums of some ten terms of size 1 taken in another order.
REASSOCIATED = 1e-13


def test_the_scalar_far_field_is_the_weighted_sum_of_the_colour_polynomials():
    rng = np.random.default_rng(4)
    poly = rng.normal(size=(4, 4, 3, 7, 7))
    xs, ys = np.sort(rng.uniform(0, 64, 37)), np.sort(rng.uniform(0, 64, 29))
    expected = far_field_reference(poly, xs, ys, 16.0) @ MASK_LUMA
    got = far_field_grid(poly, xs, ys, 16.0, scalar=MASK_LUMA)
    assert got.shape == (29, 37, 1)
    np.testing.assert_allclose(got[..., 0], expected, rtol=0, atol=REASSOCIATED)
    added = far_field_grid(poly, xs, ys, 16.0, out=np.ones((29, 37, 1)), scalar=MASK_LUMA, order=4)
    truncated = poly.copy()
    truncated[..., 5:, :] = truncated[..., :, 5:] = 0.0
    np.testing.assert_allclose(added[..., 0], 1.0 + far_field_reference(truncated, xs, ys, 16.0) @ MASK_LUMA,
                               rtol=0, atol=REASSOCIATED)


def test_the_scalar_near_points_are_the_weighted_sum_of_their_colours():
    points = build(Document(128, 128, points=random_points(200, 128, seed=6, radii=(0.5, 30.0)))).points
    assert len(points.near) > 20
    xs = sample_coordinates(96, 128, 1)
    colour = near_grid(points.near, xs, xs)
    np.testing.assert_allclose(near_grid(points.near, xs, xs, scalar=MASK_LUMA)[..., 0], colour @ MASK_LUMA,
                               rtol=0, atol=REASSOCIATED)
    assert np.abs(colour).max() > 0.1


def test_the_points_kernels_leave_skipped_cells_as_they_are():
    points = build(Document(128, 128, points=random_points(200, 128, seed=8, radii=(0.5, 30.0)))).points
    n, size = points.near.lattice.cells_per_side, points.near.lattice.cell_size
    skip = np.random.default_rng(3).random((n, n)) < 0.5
    xs = sample_coordinates(96, 128, 2)
    inside = np.minimum((xs // size).astype(int), n - 1)
    skipped = skip[inside][:, inside]
    whole = np.zeros((len(xs), len(xs), 1))
    points.add_grid(8, xs, xs, whole, MASK_LUMA)
    out = np.full_like(whole, np.nan)
    out[~skipped] = 0.0
    points.add_grid(8, xs, xs, out, MASK_LUMA, skip)
    assert np.isnan(out[skipped]).all() and skipped.any()
    np.testing.assert_array_equal(out[~skipped], whole[~skipped])


def test_masks_and_alpha_fields_are_read_through_one_channel_unless_read_otherwise_too():
    image, mask, alpha, both = "image", "mask", "alpha", "both"
    layers = (LayerFields(image, mask=mask), LayerFields(both, alpha=alpha), LayerFields(image, mask=both))
    reads = scalar_reads(Composite(8, 8, layers))
    assert set(reads) == {id(mask), id(alpha)}
    assert reads[id(mask)] is MASK_LUMA and reads[id(alpha)] is FIRST_CHANNEL
    # a disabled mask is not read at all
    assert scalar_reads(Composite(8, 8, (LayerFields(image, mask=mask, mask_enabled=False),))) == {}


@pytest.mark.parametrize("coverage", [False, True])
def test_compose_takes_a_mask_and_an_alpha_as_their_one_channel(coverage):
    rng = np.random.default_rng(2)
    values = {name: rng.uniform(-0.5, 1.5, (6, 5, 3)) for name in ("bottom", "image", "mask", "alpha")}
    picture = Composite(5, 6, (LayerFields("bottom", opacity=0.5),
                               LayerFields("image", mask="mask", mask_inverted=True, alpha="alpha", opacity=0.9)))
    scalar = dict(values, mask=values["mask"] @ MASK_LUMA[:, None], alpha=values["alpha"][..., :1])
    np.testing.assert_allclose(compose(picture, scalar.__getitem__, (6, 5, 3), coverage),
                               compose_reference(picture, values.__getitem__, (6, 5, 3), coverage), rtol=0,
                               atol=1e-14)


@pytest.fixture(scope="module")
def soft():
    """``three_layers``: its middle layer under a soft mask (points alone), its top one under a curve mask; and that
    picture with an alpha field of points alone on its top layer."""
    picture = LiveStack(three_layers()).composite
    bottom, middle, top = picture.shown
    assert not len(middle.mask.near[0].p) and middle.mask.points is not None and len(top.mask.near[0].p)
    alpha = build(Document(SIZE, SIZE, points=soft_mask(9).points))
    return picture, replace(picture, layers=(bottom, middle, replace(top, alpha=alpha)))


@pytest.mark.parametrize("with_alpha", [False, True])
def test_a_soft_mask_is_rasterised_in_one_channel_as_its_colour_would_give(soft, with_alpha, monkeypatch):
    picture = soft[with_alpha]
    channels, add_grid = [], PointField.add_grid

    def counted(field, order, xs, ys, out, *args):
        channels.append(out.shape[-1])
        return add_grid(field, order, xs, ys, out, *args)

    monkeypatch.setattr(PointField, "add_grid", counted)
    one = rasterise(picture, 100, samples=2, coverage=True)
    fields = 2 if with_alpha else 1
    assert channels == [1] * fields
    channels.clear()
    monkeypatch.setattr(raster, "scalar_reads", lambda composite: {})
    colour = rasterise(picture, 100, samples=2, coverage=True)
    assert channels == [3] * fields
    np.testing.assert_allclose(one, colour, rtol=0, atol=REASSOCIATED)
    assert np.ptp(one[..., :3]) > 0.5
    if with_alpha:  # the alpha field shows
        assert np.abs(one - rasterise(soft[0], 100, samples=2, coverage=True)).max() > 0.1
