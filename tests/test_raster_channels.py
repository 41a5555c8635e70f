"""The raster kernels of four channels (colour and an alpha field with the same segments) against three.

Each channel of a kernel's four is computed as the three-channel kernel computes a channel, so the colour of
a four-channel run equals a three-channel run of the colour, and its fourth channel a three-channel run of
that channel alone, to rounding: the far field's and the sub-cells' expansions are compiled to reassociate
(their vector code differs with the channels), and a segment without E in three channels but with E in four
has its double layer from another closed form in the three-channel run (without its single layer).
"""

from __future__ import annotations

import gc
import weakref
from dataclasses import replace

import numpy as np
import pytest
from layered import translucent_layers
from test_raster import chains_and_strays
from test_raster_single import sample_bounds
from test_raster_subcells import random_expansions

from fmr_editor.engine import LayerFields, raster, rasterise
from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells
from fmr_editor.engine.fmm.orders import sample_degrees
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels import grid
from fmr_editor.engine.kernels.grid import near_field_grid
from fmr_editor.engine.kernels.local_grid import local_field_grid
from fmr_editor.engine.kernels.subcells import subcell_field_grid
from fmr_editor.engine.raster import sample_coordinates
from fmr_editor.engine.stack import LiveStack


def split_channels(four: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segments' E or C of four channels ``(k, 4)`` as their colour ``(k, 3)`` and their fourth channel thrice."""
    return np.ascontiguousarray(four[:, :3]), np.ascontiguousarray(four[:, [3, 3, 3]])


#: What sums of some ten terms of size 1 computed in another order or form may differ by, in float64 and in
#: float32 (``kernels.single``).
REASSOCIATED, REASSOCIATED_SINGLE = 1e-14, 1e-6


def assert_channels_match(four_channels, colour_run, fourth_run, atol=REASSOCIATED):
    np.testing.assert_allclose(four_channels[..., :3], colour_run, rtol=0, atol=atol)
    np.testing.assert_allclose(four_channels[..., 3], fourth_run[..., 0], rtol=0, atol=atol)


@pytest.fixture(scope="module")
def segments():
    """Chains and strays of four channels on a 64-pixel lattice of 8 cells (their E small, as on real files; the
    first 30 without E, as the canvas border's, the next 15 with E in the fourth channel alone)."""
    rng = np.random.default_rng(8)
    lattice = Lattice(3, 64.0)
    base = chains_and_strays(rng, 64, 64, np.array([20.0, 30.0]))
    k = len(base.p)
    flux = 0.02 * rng.normal(size=(k, 4))
    flux[:30] = 0.0
    flux[30:45, :3] = 0.0
    four = Segments(base.p, base.q, jump=rng.uniform(-1, 1, (k, 4)), mean=np.zeros((k, 4)), on_border=base.on_border,
                    flux=flux)
    seg, start = sort_into_cells(four, lattice)
    return lattice, seg, start


@pytest.mark.parametrize("samples_a_side", [2, 6])  # near_rows, then the column visits
@pytest.mark.parametrize("precision", ["double", "single"])
def test_four_channel_near_field_is_three_channel_runs(segments, samples_a_side, precision, monkeypatch):
    lattice, seg, start = segments
    if precision == "single":  # every visit in float32, so that both runs take the same path everywhere
        monkeypatch.setattr(grid, "SINGLE_BUDGET", np.inf)
    xs = sample_coordinates(8 * samples_a_side, 64, 1)
    ys = sample_coordinates(8 * samples_a_side, 64, 1)[1:-3]

    def near(flux, jump):
        return near_field_grid(xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, flux, jump,
                               precision=precision)

    four = near(seg.flux, seg.jump)
    assert four.shape == (len(ys), len(xs), 4)
    flux, flux_fourth = split_channels(seg.flux)
    jump, jump_fourth = split_channels(seg.jump)
    assert_channels_match(four, near(flux, jump), near(flux_fourth, jump_fourth),
                          atol=REASSOCIATED if precision == "double" else REASSOCIATED_SINGLE)
    assert np.abs(four[..., 3] - four[..., 0]).max() > 0.1  # the fourth channel is a field of its own


def test_four_channel_single_precision_stays_within_its_bound(segments):
    lattice, seg, start = segments
    xs, ys = np.arange(0.25, 64, 1.5), np.arange(0.5, 64, 2.5)
    args = (xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    double, single_field = near_field_grid(*args), near_field_grid(*args, precision="single")
    assert np.abs(single_field - double).max() > 0  # the float32 kernel ran
    assert (np.abs(single_field - double).max(axis=2) <= sample_bounds(lattice, xs, ys, seg, start)).all()


def first_thrice(values: np.ndarray | None) -> np.ndarray | None:
    """Expansions ``(n, n, k, terms)`` or centre values ``(n, n, k)`` with their first channel in all three."""
    return None if values is None else np.ascontiguousarray(np.repeat(values[:, :, :1], 3, axis=2))


@pytest.mark.parametrize("samples_a_side", [2, 6])  # by Horner, by the powers of w
def test_four_channel_far_field_is_three_channel_runs(samples_a_side):
    rng = np.random.default_rng(samples_a_side)
    local, other = random_expansions(rng, 8, 11), random_expansions(rng, 8, 11)  # the other's first is the fourth
    coordinates = sample_coordinates(8 * samples_a_side, 64, 1)
    on_centres = (np.arange(8) + 0.5) * 8.0  # degree 0 everywhere: the centre values are read
    for xs, centres, other_centres in ((coordinates, None, None),
                                       (on_centres, rng.normal(size=(8, 8, 3)), rng.normal(size=(8, 8, 3)))):

        def far(expansions, centre_values, fourth=None):
            return local_field_grid(expansions, 8, xs, xs, 8.0, centres=centre_values, degrees=sample_degrees(8),
                                    fourth=fourth)

        four = far(local, centres, (other, other_centres))
        assert four.shape == (len(xs), len(xs), 4)
        assert_channels_match(four, far(local, centres), far(first_thrice(other), first_thrice(other_centres)))


@pytest.mark.parametrize("split", [2, 4])
def test_four_channel_sub_cells_are_three_channel_runs(segments, split):
    lattice, seg, start = segments
    rng = np.random.default_rng(split)
    local, other = random_expansions(rng, 8, 9), random_expansions(rng, 8, 9)
    xs = sample_coordinates(8 * 16, 64, 1)

    def field(expansions, flux, jump, fourth=None):
        return subcell_field_grid(expansions, 8, xs, xs, lattice.cell_size, start, seg.p, seg.q, flux, jump,
                                  split=split, fourth=fourth)

    four = field(local, seg.flux, seg.jump, (other, None))
    flux, flux_fourth = split_channels(seg.flux)
    jump, jump_fourth = split_channels(seg.jump)
    assert_channels_match(four, field(local, flux, jump), field(first_thrice(other), flux_fourth, jump_fourth))


@pytest.fixture(scope="module")
def translucent():
    """Three layers, two of them translucent, one of those with points of its own (``layered``)."""
    return LiveStack(translucent_layers()).composite


def test_a_translucent_layer_is_rasterised_with_its_alpha_in_one_pass(translucent, monkeypatch):
    carried = [layer for layer in translucent.shown if layer.carries_alpha]
    assert len(carried) == 2 and any(layer.image.points is not None for layer in carried)
    evaluated, evaluate = [], raster._fmr_samples
    monkeypatch.setattr(raster, "_fmr_samples", lambda rep, *args: evaluated.append(rep) or evaluate(rep, *args))
    monkeypatch.setattr(raster, "NEAR_PRECISION", "double")  # both ways take the same kernels' paths
    together = rasterise(translucent, 96, samples=2)
    assert not {id(layer.alpha) for layer in carried} & {id(rep) for rep in evaluated}

    evaluated.clear()
    monkeypatch.setattr(LayerFields, "carries_alpha", property(lambda layer: False))
    apart = rasterise(translucent, 96, samples=2)
    assert {id(layer.alpha) for layer in carried} <= {id(rep) for rep in evaluated}
    np.testing.assert_allclose(together, apart, rtol=0, atol=REASSOCIATED)
    assert np.ptp(together) > 0.5


@pytest.mark.parametrize("other_alpha", ["its own", "the image itself"])  # carried by one layer, by both
def test_an_image_two_layers_show_is_evaluated_with_neither_alpha(translucent, other_alpha, monkeypatch):
    bottom, middle, top = translucent.shown
    second = replace(middle, image=top.image) if other_alpha == "its own" else replace(top, alpha=top.image)
    shared = replace(translucent, layers=(bottom, second, top))
    assert top.carries_alpha and second.carries_alpha == (other_alpha == "the image itself")
    monkeypatch.setattr(raster, "NEAR_PRECISION", "double")
    together = rasterise(shared, 96, samples=1)
    monkeypatch.setattr(LayerFields, "carries_alpha", property(lambda layer: False))
    np.testing.assert_allclose(together, rasterise(shared, 96, samples=1), rtol=0, atol=REASSOCIATED)


def test_an_image_keeps_what_it_was_joined_with_but_not_the_alpha_field(translucent):
    layer = next(layer for layer in translucent.shown if layer.carries_alpha)
    flux, jump, tables, bounds = joined = layer.image.joined_with(layer.alpha)
    assert layer.image.joined_with(layer.alpha) is joined
    np.testing.assert_array_equal(flux, np.c_[layer.image.near[0].flux, layer.alpha.near[0].flux[:, 0]])
    np.testing.assert_array_equal(jump, np.c_[layer.image.near[0].jump, layer.alpha.near[0].jump[:, 0]])
    other = replace(layer.alpha)  # an equal field, another object: joined again
    assert layer.image.joined_with(other) is not joined
    kept = weakref.ref(other)
    del other
    gc.collect()
    assert kept() is None
