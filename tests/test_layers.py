"""Layers and masks: the model's stack and its edits, and the engine's composite against per-pixel composition."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from layered import GREEN, SIZE, paint_over_glow, reference, three_layers, translucent_layers, with_alphas
from shapes import scattered_document

from fmr_editor.engine import LiveStack, evaluate_points, raster, rasterise
from fmr_editor.model import DiffusionPoint, Document, EditRefused, Layer, edits, layer_edits
from fmr_editor.model.color_transform import hue_rotation, inversion
from fmr_editor.model.history import History

PIXELS = 48
ONE_STEP = 1 / 255


# -- the model ---------------------------------------------------------------------------------------------------


def test_a_document_of_curves_is_one_plain_layer_and_edits_act_on_the_target():
    flat = scattered_document(64, seed=1)
    assert len(flat.layers) == 1 and flat.is_flat and flat.curves is flat.layers[0].curves
    layered = layer_edits.add_layer(flat)
    assert layered.active == 1 and layered.curves == () and not layered.is_flat
    drawn = edits.add_curve(layered, flat.curves[0])
    assert drawn.layers[0] == flat.layers[0] and drawn.layers[1].curves == (flat.curves[0],)
    masked = layer_edits.select_layer(layer_edits.add_mask(drawn), 1, mask=True)
    dabbed = edits.add_points(masked, [DiffusionPoint((3, 4), 5, (1, 1, 1))])
    assert dabbed.layers[1].points == () and len(dabbed.layers[1].mask.points) == 1
    assert dabbed.layers[1].mask.base == 1.0


def test_the_active_layer_follows_its_layer_through_moves_and_deletions():
    document = Document(8, 8, layers=[Layer(name=name) for name in "abcd"], active=1)
    moved = layer_edits.move_layer(document, 1, 3)
    assert [layer.name for layer in moved.layers] == list("acdb") and moved.layer.name == "b"
    assert layer_edits.move_layer(document, 3, 0).layer.name == "b"
    assert layer_edits.remove_layer(document, 1).layer.name == "a"
    assert layer_edits.remove_layer(document, 3).layer.name == "b"
    copy = layer_edits.duplicate_layer(document, 2)
    assert [layer.name for layer in copy.layers] == ["a", "b", "c", "c copy", "d"] and copy.active == 3
    assert copy.layers[3].id != copy.layers[2].id
    with pytest.raises(EditRefused, match="at least one layer"):
        layer_edits.remove_layer(Document(8, 8))


@pytest.mark.parametrize("opacity", [-0.1, 1.5, math.nan, math.inf, "half"])
def test_opacity_outside_the_unit_interval_is_refused(opacity):
    with pytest.raises(ValueError, match="opacity"):
        layer_edits.set_opacity(Document(8, 8), 0, opacity)


def test_a_document_holds_at_most_200_layers_of_names_up_to_1000_characters():
    full = Document(8, 8, layers=[Layer(name=str(i)) for i in range(200)], active=199)
    with pytest.raises(EditRefused, match="at most 200 layers"):
        layer_edits.add_layer(full)
    with pytest.raises(EditRefused, match="at most 1000 characters"):
        layer_edits.rename_layer(full, 0, "x" * 1001)
    assert layer_edits.rename_layer(full, 0, "x" * 1000).layers[0].name == "x" * 1000


def test_undo_and_redo_of_every_layer_action_restore_the_document_exactly():
    actions = [
        ("Add Layer", layer_edits.add_layer),
        ("Rename Layer", lambda d: layer_edits.rename_layer(d, None, "sky")),
        ("Opacity", lambda d: layer_edits.set_opacity(d, None, 0.25)),
        ("Add Mask", layer_edits.add_mask),
        ("Invert Mask", layer_edits.invert_mask),
        ("Disable Mask", lambda d: layer_edits.set_mask_enabled(d, None, False)),
        ("Colour Adjust", lambda d: layer_edits.set_transform(d, None, hue_rotation(40).then(inversion()))),
        ("Hide Layer", lambda d: layer_edits.set_visible(d, None, False)),
        ("Duplicate Layer", layer_edits.duplicate_layer),
        ("Move Layer", lambda d: layer_edits.move_layer(d, 2, 0)),
        ("Delete Mask", layer_edits.remove_mask),
        ("Delete Layer", layer_edits.remove_layer),
    ]
    history = History(scattered_document(64, seed=1))
    seen = [history.document]
    for label, action in actions:
        history.apply(action(history.document), label)
        seen.append(history.document)
    assert history.labels[1:] == tuple(label for label, _ in actions)
    for expected in reversed(seen[:-1]):
        history.undo()
        assert history.document == expected
    for expected in seen[1:]:
        history.redo()
        assert history.document == expected


# -- the composite -----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def stack() -> LiveStack:
    return LiveStack(three_layers())


def test_the_composite_equals_per_pixel_composition_of_the_layers(stack):
    document = stack.document
    expected = reference(document, PIXELS, PIXELS)
    got = rasterise(stack.composite, PIXELS, PIXELS, samples=1)
    assert np.abs(got - expected).max() < ONE_STEP
    # each ingredient matters: the check would fail without the mask, the opacity or the hue
    for changed in (layer_edits.remove_mask(document, 2), layer_edits.set_opacity(document, 1, 1.0),
                    layer_edits.set_transform(document, 2, hue_rotation(0))):
        assert np.abs(reference(changed, PIXELS, PIXELS) - expected).max() > 10 * ONE_STEP


def test_paint_over_a_glow_blends_with_the_white_shown_there_and_leaves_no_fringe():
    document = paint_over_glow()
    stack = LiveStack(document)
    xs = (np.arange(PIXELS) + 0.5) * SIZE / PIXELS
    grid = np.stack(np.meshgrid(xs, xs), axis=-1).reshape(-1, 2)
    glow = evaluate_points(stack.image(document.layers[0]), grid)
    white = (glow >= 1).all(axis=1)  # shown white; underneath (4, 3.6, 2.4) at the centre
    assert white.mean() > 0.2 and glow.max() > 3
    got = evaluate_points(stack.composite, grid)[white]
    weight = (1 - got) / (1 - np.array(GREEN))  # got = k GREEN + (1 - k) white: the same k in every channel
    painted = weight[:, 0] > 0.05
    assert painted.mean() > 0.1 and (weight <= 1 + 1e-9).all()
    assert np.abs(weight - weight[:, :1]).max() < 1e-9  # on the segment from white to green: no yellow
    np.testing.assert_allclose(got, reference(document, PIXELS, PIXELS).reshape(-1, 3)[white], atol=ONE_STEP)


def test_the_curve_mask_is_the_indicator_of_its_circle(stack):
    mask = stack.mask(stack.document.layers[2])
    inside, outside = [(60, 70), (40, 60)], [(5, 5), (120, 120), (60, 20)]
    values = evaluate_points(mask, np.array(inside + outside)) @ np.array([0.2126, 0.7152, 0.0722])
    np.testing.assert_allclose(values, [1, 1, 0, 0, 0], atol=1e-3)


def test_the_composite_at_any_points_equals_the_composite_image(stack, monkeypatch):
    monkeypatch.setattr(raster, "NEAR_PRECISION", "double")  # points are summed in float64
    xs = (np.arange(PIXELS) + 0.5) * SIZE / PIXELS
    grid = np.stack(np.meshgrid(xs, xs), axis=-1).reshape(-1, 2)
    image = rasterise(stack.composite, PIXELS, PIXELS, samples=1)
    np.testing.assert_allclose(evaluate_points(stack.composite, grid).reshape(PIXELS, PIXELS, 3), image, atol=1e-9)


def test_a_composite_is_black_off_the_canvas_whatever_its_transforms():
    inverted = layer_edits.set_transform(Document(SIZE, SIZE, scattered_document(SIZE).curves), 0, inversion())
    outside = np.array([[-3.0, 5.0], [SIZE + 1.0, 7.0], [4.0, SIZE + 0.5]])
    assert not evaluate_points(LiveStack(inverted).composite, outside).any()


def test_a_covering_layer_hides_everything_below_and_hidden_layers_do_not_show():
    document = three_layers()
    on_top = Layer(scattered_document(SIZE, seed=9).curves)
    covered = layer_edits.add_layer(layer_edits.select_layer(document, 2), on_top)
    stack = LiveStack(covered)
    alone = rasterise(stack.image(covered.layers[3]), PIXELS, PIXELS, samples=1)
    np.testing.assert_array_equal(rasterise(stack.composite, PIXELS, PIXELS, samples=1), alone)
    hidden = layer_edits.set_visible(covered, 3, False)
    stack.update(hidden)
    np.testing.assert_allclose(rasterise(stack.composite, PIXELS, PIXELS, samples=1),
                               reference(document, PIXELS, PIXELS), atol=ONE_STEP)


# -- incremental edits -------------------------------------------------------------------------------------------


def representations(stack: LiveStack) -> dict:
    """Each field's arrays (a representation is a new object on each access; its arrays are replaced, never changed)."""
    return {key: Same(live.representation) for key, live in stack.fields.items()}


class Same:
    """A representation compared by the identity of its arrays."""

    def __init__(self, rep) -> None:
        points = (rep.points.tensor, rep.points.near) if rep.points is not None else ()
        self.arrays = (rep.local, rep.segments, rep.cell_start, *points)

    def __eq__(self, other: object) -> bool:
        return all(a is b for a, b in zip(self.arrays, other.arrays))


def test_an_edit_to_one_layer_touches_only_that_layer_and_equals_a_fresh_build():
    document = three_layers()
    stack = LiveStack(document)
    before = representations(stack)
    top = document.layers[2]
    moved = edits.move_control_point(layer_edits.select_layer(document, 2), top.curves[0].id, 0, (30.0, 40.0))
    update = stack.update(moved)
    assert set(update.fields) == {(top.id, "image")} and update.kind == "geometry"
    after = representations(stack)
    for key in before:
        assert (after[key] == before[key]) == (key != (top.id, "image"))
    fresh = LiveStack(moved)
    np.testing.assert_allclose(rasterise(stack.composite, PIXELS, PIXELS, samples=1),
                               rasterise(fresh.composite, PIXELS, PIXELS, samples=1), atol=0.25 / 255)


def test_a_mask_dab_updates_only_the_mask_and_hue_or_opacity_solve_nothing():
    document = three_layers()
    stack = LiveStack(document)
    middle = document.layers[1]
    dab = DiffusionPoint((40.0, 40.0), 12.0, (1.0, 1.0, 1.0))
    dabbed = edits.add_points(layer_edits.select_layer(document, 1, mask=True), [dab])
    update = stack.update(dabbed)
    assert set(update.fields) == {(middle.id, "mask")} and update.kind == "points"
    for change in (layer_edits.set_transform(dabbed, 1, hue_rotation(33)), layer_edits.set_opacity(dabbed, 1, 0.2)):
        before = representations(stack)
        assert stack.update(change).fields == {}
        assert representations(stack) == before
        np.testing.assert_allclose(rasterise(stack.composite, PIXELS, PIXELS, samples=1),
                                   reference(change, PIXELS, PIXELS), atol=ONE_STEP)


def test_undoing_a_deletion_takes_the_layer_back_without_a_solve():
    document = three_layers()
    stack = LiveStack(document)
    kept = representations(stack)
    stack.update(layer_edits.remove_layer(document, 1))
    assert stack.update(document).fields == {}
    assert representations(stack) == kept


# -- baking transforms, merging ------------------------------------------------------------------------------------


def test_a_baked_transform_gives_the_same_image_without_a_transform(monkeypatch):
    monkeypatch.setattr(raster, "NEAR_PRECISION", "double")  # the same sums in either order (float32 rounds each)
    layer = Layer(scattered_document(SIZE, seed=5).curves, transform=hue_rotation(70).then(inversion()),
                  points=[DiffusionPoint((40, 50), 15, (0.2, 0.5, 0.9), 0.7)])
    document = Document(SIZE, SIZE, layers=(layer,))
    baked = layer_edits.baked(layer)
    assert baked.transform.is_identity and baked != layer
    stack = LiveStack(document)
    transformed = rasterise(stack.composite, PIXELS, PIXELS, samples=1)
    plain = rasterise(stack.representation, PIXELS, PIXELS, samples=1)
    exact = ((plain >= 0) & (plain <= 1)).all(axis=-1)  # the layer clamps V before T: baking is exact there
    assert 0.5 < exact.mean() < 1
    baked_image = rasterise(LiveStack(document.with_layer(0, baked)).composite, PIXELS, PIXELS, samples=1)
    np.testing.assert_allclose(baked_image[exact], transformed[exact], atol=1e-6)


def test_merge_down_joins_the_items_with_transforms_applied_and_keeps_the_lower_layer():
    masked = three_layers()
    with pytest.raises(EditRefused, match="mask and opacity cannot be kept.*; middle's mask and opacity below 100%"):
        layer_edits.merge_down(masked, 2)  # every reason at once: the upper layer's and the lower one's
    document = layer_edits.remove_mask(masked, 2)
    with pytest.raises(EditRefused, match="^middle's mask and opacity below 100% would weigh top's items too"):
        layer_edits.merge_down(document, 2)  # the lower layer's mask and opacity would fall on the upper items
    with pytest.raises(EditRefused, match="^middle's mask would weigh"):
        layer_edits.merge_down(layer_edits.set_opacity(document, 1, 1.0), 2)  # its mask alone
    document = layer_edits.set_opacity(layer_edits.remove_mask(document, 1), 1, 1.0)
    with pytest.raises(EditRefused, match="show both layers"):
        layer_edits.merge_down(layer_edits.set_visible(document, 1, False), 2)
    merged = layer_edits.merge_down(document, 2)
    assert [layer.name for layer in merged.layers] == ["bottom", "middle"] and merged.active == 1
    middle, top = document.layers[1], layer_edits.baked(document.layers[2])
    assert merged.layers[1].curves == middle.curves + top.curves
    assert merged.layers[1].mask is None and merged.layers[1].opacity == 1.0
    with pytest.raises(EditRefused, match="no layer below"):
        layer_edits.merge_down(document, 0)


def test_merge_down_refuses_a_translucent_lower_layer():
    document = layer_edits.remove_mask(translucent_layers(), 2)  # the middle layer's circles: clear outside
    document = layer_edits.set_opacity(layer_edits.remove_mask(document, 1), 1, 1.0)
    top = document.layers[2]
    document = document.with_layer(2, replace(top, curves=tuple(with_alphas(c, 1.0, 1.0) for c in top.curves)))
    assert document.layers[1].translucent and not document.layers[2].translucent
    with pytest.raises(EditRefused, match="^middle's colour stops with alpha below 1 would weigh top's items"):
        layer_edits.merge_down(document, 2)


def test_flatten_merges_the_visible_layers_into_one_and_drops_hidden_ones():
    document = layer_edits.set_visible(layer_edits.remove_mask(three_layers(), 2), 1, False)
    flat = layer_edits.flatten(document)
    bottom, top = document.layers[0], layer_edits.baked(document.layers[2])
    assert len(flat.layers) == 1 and flat.active == 0 and flat.layers[0].name == "bottom"
    assert flat.layers[0].curves == bottom.curves + top.curves
    with pytest.raises(EditRefused, match="no layer is visible"):
        layer_edits.flatten(layer_edits.set_visible(Document(8, 8), 0, False))
