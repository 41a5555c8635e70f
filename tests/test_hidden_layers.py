"""A layered raster evaluates each layer's image only where it can show: against the plain composition of whole fields.

Where a layer's weight is 0 (its mask hides it) or a layer above it weighs 1 (covers it), each to
``composite.NEGLIGIBLE_WEIGHT``, its image is not evaluated (``composite.hidden``, ``raster.hidden_cells``); the
kernels' ``skip`` leaves those cells out and every other sample as without it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from layered import SIZE, three_layers

from fmr_editor.engine import LiveStack, Settings, build, raster, rasterise
from fmr_editor.engine.composite import NEGLIGIBLE_WEIGHT, Composite, compose_reference, hidden, settled
from fmr_editor.engine.kernels.grid import cells_all, grid_cell_runs, near_field_grid
from fmr_editor.engine.kernels.subcells import subcell_field_grid
from fmr_editor.engine.raster import sample_coordinates
from fmr_editor.model import Document, layer_edits
from fmr_editor.model.color_transform import hue_rotation
from fmr_editor.model.layer import MASK_LUMA

PIXELS = 96


@pytest.fixture(scope="module")
def stack() -> LiveStack:
    return LiveStack(three_layers())


@pytest.fixture(scope="module")
def fields(stack):
    """Every field of the composite rasterised whole, by the identity of its representation."""
    return {id(rep): rasterise(rep, PIXELS, PIXELS, samples=1) for rep in stack.composite.representations}


def test_hidden_samples_are_those_of_negligible_weight_or_under_a_layer_of_full_weight(stack, fields):
    picture = stack.composite
    count = PIXELS * PIXELS
    got = hidden(picture, lambda rep: fields[id(rep)], count)
    covered = np.zeros(count, bool)
    for layer, where in reversed(list(zip(picture.shown, got))):
        weight = np.broadcast_to(layer.weight(fields[id(layer.mask)].reshape(-1, 3) if layer.masked else None), count)
        np.testing.assert_array_equal(where, covered | (weight <= NEGLIGIBLE_WEIGHT))
        covered = covered | (weight >= 1 - NEGLIGIBLE_WEIGHT)
    bottom, middle, top = got
    assert 0.3 < top.mean() < 0.8  # the top layer's circle mask hides it outside the circle
    assert 0.1 < bottom.mean() < 0.7 and not (bottom & top).any()  # and covers what lies below inside it alone


def test_a_layered_raster_leaves_hidden_cells_out_and_equals_the_composition_of_whole_fields(stack, fields,
                                                                                             monkeypatch):
    monkeypatch.setattr(raster, "BOUNDED_SAMPLES", 0)  # the masks' bounds at any density (``test_mask_bounds``)
    skips, evaluate = {}, raster.subcell_field_grid
    def recorded(local, *args, skip=None, **kwargs):
        skips[id(local)] = skip
        return evaluate(local, *args, skip=skip, **kwargs)

    monkeypatch.setattr(raster, "subcell_field_grid", recorded)
    picture = stack.composite
    got = rasterise(picture, PIXELS, PIXELS, samples=1)
    expected = compose_reference(picture, lambda rep: fields[id(rep)], (PIXELS, PIXELS, 3))
    assert np.abs(got - expected).max() <= NEGLIGIBLE_WEIGHT
    bottom, middle, top = (skips[id(layer.image.local)] for layer in picture.shown)
    assert 0.1 < bottom.mean() < 0.5 and 0.3 < top.mean() < 0.8  # cells left out: under the circle, outside it
    assert middle is None or not middle.all()
    # a mask but where its bounds settle its layer's weight (one of points alone has no segment to evaluate:
    # ``Representation.near``)
    for layer in picture.shown:
        if layer.masked and len(layer.mask.near[0].p):
            settles = settled(layer, *layer.mask.scalar_bounds(MASK_LUMA))
            np.testing.assert_array_equal(skips[id(layer.mask.local)], settles)
            assert 0.2 < settles.mean() < 0.9


def test_bands_of_any_height_leave_hidden_cells_out_and_give_the_same_picture(stack, monkeypatch):
    """Each band finds its own hidden cells; the picture does not depend on them (a hidden sample's value is not
    read; bands change the rest by rounding, as in a one-layer raster), and a band holds its masks and one image
    at a time: its rows shrink with the masks it holds."""
    whole = rasterise(stack.composite, PIXELS, PIXELS, samples=1)
    heights, evaluate = [], raster.subcell_field_grid
    monkeypatch.setattr(raster, "subcell_field_grid", lambda local, order, xs, ys, *args, **kwargs:
                        heights.append(len(ys)) or evaluate(local, order, xs, ys, *args, **kwargs))
    monkeypatch.setattr(raster, "BAND_SAMPLES", 30 * PIXELS)
    np.testing.assert_allclose(rasterise(stack.composite, PIXELS, PIXELS, samples=1), whole, rtol=0, atol=1e-12)
    masks = len(raster._weighing(stack.composite))
    assert masks == 2 and set(heights) == {30 // (1 + masks), PIXELS % (30 // (1 + masks))}


def test_an_image_two_layers_show_is_evaluated_wherever_either_shows_it(stack, fields):
    """One representation under two layers: hidden under the top one inside its circle (covered), hidden as the
    top one outside it (its mask 0); it is left out only where both hide it, here nowhere."""
    bottom, top = stack.composite.shown[0], stack.composite.shown[2]
    twice = Composite(SIZE, SIZE, (bottom, replace(top, image=bottom.image)))
    got = rasterise(twice, PIXELS, PIXELS, samples=1)
    expected = compose_reference(twice, lambda rep: fields[id(rep)], (PIXELS, PIXELS, 3))
    assert np.abs(got - expected).max() <= NEGLIGIBLE_WEIGHT


def test_a_layer_its_mask_hides_everywhere_evaluates_no_cell(monkeypatch):
    monkeypatch.setattr(raster, "BOUNDED_SAMPLES", 0)
    nowhere = layer_edits.set_opacity(layer_edits.set_opacity(three_layers(), 1, 0.0), 2, 0.0)
    stack = LiveStack(nowhere)
    skips, evaluate = [], raster.subcell_field_grid
    monkeypatch.setattr(raster, "subcell_field_grid",
                        lambda local, *args, skip=None, **kwargs: skips.append(skip) or evaluate(local, *args,
                                                                                                  skip=skip, **kwargs))
    got = rasterise(stack.composite, PIXELS, PIXELS, samples=1)
    np.testing.assert_array_equal(got, np.clip(rasterise(stack.image(nowhere.layers[0]), PIXELS, PIXELS, samples=1),
                                               0, 1))
    assert sum(skip is not None and skip.all() for skip in skips) == 3  # the two transparent layers, a mask of one


def test_cells_all_is_the_conjunction_over_each_cells_run_of_samples():
    rng = np.random.default_rng(4)
    xs, ys = np.sort(rng.uniform(0, 64, 90)), np.sort(rng.uniform(0, 64, 70))
    flags = rng.random((70, 90)) < 0.97
    flags[:, 40:] = True
    x_start, y_start = grid_cell_runs(xs, 8.0, 8), grid_cell_runs(ys, 8.0, 8)
    got = cells_all(flags, x_start, y_start)
    for cy in range(8):
        for cx in range(8):
            assert got[cy, cx] == flags[y_start[cy]:y_start[cy + 1], x_start[cx]:x_start[cx + 1]].all()
    assert got.any() and not got.all()


@pytest.fixture(scope="module")
def rep():
    return build(Document(SIZE, SIZE, three_layers().layers[0].curves), Settings(levels=4))


@pytest.mark.parametrize("samples_per_cell, split", [(8, 1), (32, 2)])
def test_the_kernels_give_every_sample_outside_skipped_cells_what_they_give_without_skip(rep, samples_per_cell, split):
    lattice, seg = rep.lattice, rep.segments
    n = lattice.cells_per_side
    xs = sample_coordinates(n * samples_per_cell, SIZE, 1)
    skip = np.random.default_rng(3).random((n, n)) < 0.5
    skip[5] = True  # a whole row: its samples get nothing
    args = (rep.local, rep.order, xs, xs, lattice.cell_size, rep.cell_start, seg.p, seg.q, seg.flux, seg.jump)
    whole = subcell_field_grid(*args, split=split, out=np.zeros((len(xs), len(xs), 3)))
    some = subcell_field_grid(*args, split=split, out=np.zeros((len(xs), len(xs), 3)), skip=skip)
    shown = np.repeat(np.repeat(~skip, samples_per_cell, axis=0), samples_per_cell, axis=1)
    np.testing.assert_array_equal(some[shown], whole[shown])
    assert not some[5 * samples_per_cell:6 * samples_per_cell].any() and whole[shown].any()
    near = near_field_grid(xs, xs, n, lattice.cell_size, rep.cell_start, seg.p, seg.q, seg.flux, seg.jump, skip=skip)
    np.testing.assert_array_equal(near[shown], near_field_grid(xs, xs, n, lattice.cell_size, rep.cell_start, seg.p,
                                                               seg.q, seg.flux, seg.jump)[shown])


def spy_outs(monkeypatch) -> list[np.ndarray]:
    """The arrays the raster's FMR evaluates fields into, in order."""
    outs, evaluate = [], raster._fmr_samples

    def recorded(rep, order, xs, ys, whole_ys, density, out, *args, **kwargs):
        outs.append(out)
        return evaluate(rep, order, xs, ys, whole_ys, density, out, *args, **kwargs)

    monkeypatch.setattr(raster, "_fmr_samples", recorded)
    return outs


@pytest.mark.parametrize("samples", [1, 2])
def test_a_flat_pictures_image_is_evaluated_into_the_raster_itself_and_clamped_there(stack, monkeypatch, samples):
    image = stack.composite.layers[0].image
    expected = rasterise(image, PIXELS, PIXELS, samples=samples) if samples == 1 else None
    outs, composed, compose = spy_outs(monkeypatch), [], raster.compose

    def recorded(*args, **kwargs):
        composed.append(args[4])
        return compose(*args, **kwargs)

    monkeypatch.setattr(raster, "compose", recorded)
    got = rasterise(Composite(SIZE, SIZE, (replace(stack.composite.layers[0], mask=None),)), PIXELS, PIXELS,
                    samples=samples)
    assert len(outs) == 1 and np.shares_memory(outs[0], composed[0])  # where the picture is composed
    if samples == 1:  # the picture's own pixels, no image of its own
        assert np.shares_memory(outs[0], got)
        np.testing.assert_array_equal(got, np.clip(expected, 0.0, 1.0))
    else:  # its band of samples, clamped before they are averaged
        samples_image = rasterise(image, PIXELS * samples, PIXELS * samples, samples=1)
        clamped = np.clip(samples_image, 0.0, 1.0).reshape(PIXELS, samples, PIXELS, samples, 3).mean(axis=(1, 3))
        np.testing.assert_allclose(got, clamped, rtol=0, atol=1e-12)


def test_an_image_two_layers_show_is_not_evaluated_into_the_picture(stack, fields, monkeypatch):
    """The bottom layer's image shown again above it (under a mask) is evaluated apart for each: the picture's
    pixels hold the composition, not the image, when the second reads it."""
    bottom, middle, _ = stack.composite.shown
    picture = Composite(SIZE, SIZE, (bottom, replace(bottom, mask=middle.mask, mask_base=0.0, opacity=0.6)))
    outs = spy_outs(monkeypatch)
    got = rasterise(picture, PIXELS, PIXELS, samples=1)
    assert not any(np.shares_memory(out, got) for out in outs)
    fields = dict(fields) | {id(bottom.image): rasterise(bottom.image, PIXELS, PIXELS, samples=1)}
    expected = compose_reference(picture, lambda rep: fields[id(rep)], (PIXELS, PIXELS, 3))
    assert np.abs(got - expected).max() <= NEGLIGIBLE_WEIGHT


def test_a_translucent_turned_bottom_layer_in_the_picture_itself(stack, fields, monkeypatch):
    """Blended in place under an opacity and a colour transform as its own values would be."""
    bottom = replace(stack.composite.shown[0], opacity=0.6, transform=hue_rotation(90))
    picture = Composite(SIZE, SIZE, (bottom, stack.composite.shown[2]))
    outs = spy_outs(monkeypatch)
    got = rasterise(picture, PIXELS, PIXELS, samples=1)
    assert sum(np.shares_memory(out, got) for out in outs) == 1  # the bottom image's (the top's mask comes first)
    expected = compose_reference(picture, lambda rep: fields[id(rep)], (PIXELS, PIXELS, 3))
    assert np.abs(got - expected).max() <= NEGLIGIBLE_WEIGHT
