"""The raster kernels of four channels (colour and an alpha field with the same segments) against three.

Each channel of a kernel's four is computed as the three-channel kernel computes a channel, in the same
order, so the colour of a four-channel run equals a three-channel run of the colour, and its fourth channel a
three-channel run of that channel alone: to the bit where the kernels keep the order of their operations (the
near field's, whose error bounds rely on it), to rounding where they are compiled to reassociate (the far
field's and the sub-cells' expansions, whose vector code differs with the channels).
"""

from __future__ import annotations

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
    """A four-channel array ``(..., 4, ...)`` on axis 2 or the last as its colour and its fourth channel thrice."""
    axis = 2 if four.ndim == 4 else -1
    colour = np.ascontiguousarray(np.take(four, [0, 1, 2], axis=axis))
    return colour, np.ascontiguousarray(np.take(four, [3, 3, 3], axis=axis))


#: What reassociated sums of some ten terms of size 1 may differ by.
REASSOCIATED = 1e-14


def assert_channels_match(four_channels, colour_run, fourth_run, atol=0.0):
    np.testing.assert_allclose(four_channels[..., :3], colour_run, rtol=0, atol=atol)
    np.testing.assert_allclose(four_channels[..., 3], fourth_run[..., 0], rtol=0, atol=atol)


@pytest.fixture(scope="module")
def segments():
    """Chains and strays of four channels on a 64-pixel lattice of 8 cells (their E small, as on real files; the
    first 30 without E, as the canvas border's)."""
    rng = np.random.default_rng(8)
    lattice = Lattice(3, 64.0)
    base = chains_and_strays(rng, 64, 64, np.array([20.0, 30.0]))
    k = len(base.p)
    flux = 0.02 * rng.normal(size=(k, 4))
    flux[:30] = 0.0
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
    assert_channels_match(four, near(flux, jump), near(flux_fourth, jump_fourth))
    assert np.abs(four[..., 3] - four[..., 0]).max() > 0.1  # the fourth channel is a field of its own


def test_four_channel_single_precision_stays_within_its_bound(segments):
    lattice, seg, start = segments
    xs, ys = np.arange(0.25, 64, 1.5), np.arange(0.5, 64, 2.5)
    args = (xs, ys, lattice.cells_per_side, lattice.cell_size, start, seg.p, seg.q, seg.flux, seg.jump)
    double, single_field = near_field_grid(*args), near_field_grid(*args, precision="single")
    assert np.abs(single_field - double).max() > 0  # the float32 kernel ran
    assert (np.abs(single_field - double).max(axis=2) <= sample_bounds(lattice, xs, ys, seg, start)).all()


@pytest.mark.parametrize("samples_a_side", [2, 6, 8])  # by Horner, by the powers of w, on the centres
def test_four_channel_far_field_is_three_channel_runs(samples_a_side):
    rng = np.random.default_rng(samples_a_side)
    local = random_expansions(rng, 8, 11)
    four_local = np.concatenate([local, random_expansions(rng, 8, 11)[:, :, :1]], axis=2)
    coordinates = sample_coordinates(8 * samples_a_side, 64, 1)
    on_centres = (np.arange(8) + 0.5) * 8.0
    centres = rng.normal(size=(8, 8, 4))
    for xs, kept in ((coordinates, None), (on_centres, centres)):
        options = dict(degrees=sample_degrees(8))

        def far(expansions, centre_values):
            return local_field_grid(expansions, 8, xs, xs, 8.0, centres=centre_values, **options)

        colour_centres, fourth_centres = split_channels(kept) if kept is not None else (None, None)
        colour, fourth = split_channels(four_local)
        assert_channels_match(far(four_local, kept), far(colour, colour_centres), far(fourth, fourth_centres),
                              atol=REASSOCIATED)


@pytest.mark.parametrize("split", [2, 4])
def test_four_channel_sub_cells_are_three_channel_runs(segments, split):
    lattice, seg, start = segments
    rng = np.random.default_rng(split)
    local = np.concatenate([random_expansions(rng, 8, 9), random_expansions(rng, 8, 9)[:, :, :1]], axis=2)
    xs = sample_coordinates(8 * 16, 64, 1)

    def field(expansions, flux, jump):
        return subcell_field_grid(expansions, 8, xs, xs, lattice.cell_size, start, seg.p, seg.q, flux, jump,
                                  split=split)

    four = field(local, seg.flux, seg.jump)
    colour_local, fourth_local = split_channels(local)
    flux, flux_fourth = split_channels(seg.flux)
    jump, jump_fourth = split_channels(seg.jump)
    assert_channels_match(four, field(colour_local, flux, jump), field(fourth_local, flux_fourth, jump_fourth),
                          atol=REASSOCIATED)


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
