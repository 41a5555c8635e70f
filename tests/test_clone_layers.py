"""Clone layers: copy and paste in the model, and ``LiveStack`` keeping a clone blended with what lies below it.

The clone itself is held to the raster oracle in ``test_clone.py``; here a clone layer of a document must
give exactly what ``cloning.clone_layer`` gives for the same placement over the same picture, whatever edits,
moves and undos led to it.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.engine import Composite, LiveStack, build, evaluate_points
from fmr_editor.engine.cloning import clone_layer, clone_points
from fmr_editor.engine.solve.clone import SeamlessClone
from fmr_editor.engine.stack import layer_fields
from fmr_editor.io import load_fmr
from fmr_editor.io.document_json import document_from_data, dumps_document
from fmr_editor.io.json_checks import SchemaError
from fmr_editor.model import DiffusionPoint, Document, EditRefused, edits, layer_edits
from fmr_editor.model.clone import Similarity
from fmr_editor.model.clone_edits import copy_region, paste_curves, paste_seamless, place_clone
from fmr_editor.model.color_transform import hue_rotation
from fmr_editor.model.history import History
from fmr_editor.session import Session

SIZE = 128
HEXAGON = np.array([[90.0, 62], [75, 88], [45, 88], [30, 62], [45, 36], [75, 36]])
GRID = np.stack(np.meshgrid(np.arange(2, SIZE, 3.0), np.arange(2, SIZE, 3.0)), axis=-1).reshape(-1, 2)


@pytest.fixture(scope="module")
def source() -> Document:
    dabs = [DiffusionPoint((60.0, 60.0), 9.0, (0.9, 0.2, 0.1), 0.8), DiffusionPoint((10.0, 10.0), 4.0, (0, 0, 1))]
    return scattered_document(SIZE, seed=3).with_points(dabs)


@pytest.fixture(scope="module")
def pasted(source) -> Document:
    target = scattered_document(SIZE, seed=8)
    return paste_seamless(target, copy_region(source, HEXAGON), Similarity(1.1, 20.0, (-4.0, 6.0)))


def expected(document: Document) -> np.ndarray:
    """The picture at ``GRID`` with every clone layer made afresh by ``clone_layer`` over the layers below."""
    fields = []
    for layer in document.layers:
        below = Composite(SIZE, SIZE, tuple(fields))
        if layer.clone is None:
            stack = LiveStack(Document(SIZE, SIZE, layers=(layer,)))
            fields.append(stack.composite.layers[0])
            continue
        clone = layer.clone
        seamless = SeamlessClone(build(clone.source).segments, np.asarray(clone.region), clone.similarity,
                                 canvas=(SIZE, SIZE))
        made = clone_layer(seamless, below, placed=clone_points(clone, SIZE, SIZE), layer_id=layer.id)
        fields.append(layer_fields(layer, made.image, made.mask))
    return evaluate_points(Composite(SIZE, SIZE, tuple(fields)), GRID)


def test_a_pasted_clone_layer_is_the_clone_of_its_region_over_the_layers_below(pasted):
    assert pasted.active == 1 and pasted.layer.clone is not None and pasted.layer.name == "Layer 1 clone"
    shown = evaluate_points(LiveStack(pasted).composite, GRID)
    np.testing.assert_allclose(shown, expected(pasted), atol=1e-12)
    below = evaluate_points(LiveStack(Document(SIZE, SIZE, layers=pasted.layers[:1])).composite, GRID)
    assert np.abs(shown - below).max() > 0.1  # the clone shows


def test_moving_a_clone_keeps_its_factorisation_and_equals_a_fresh_clone(pasted):
    stack = LiveStack(pasted)
    factors = stack.clones[pasted.layer.id]._seamless._factors
    moved = place_clone(pasted, 1, pasted.layer.clone.similarity.moved(7.0, -3.0))
    update = stack.update(moved)
    assert set(update.fields) == {(pasted.layer.id, "image"), (pasted.layer.id, "mask")}  # no solve
    assert stack.clones[pasted.layer.id]._seamless._factors is factors
    np.testing.assert_allclose(evaluate_points(stack.composite, GRID), expected(moved), atol=1e-9)


def test_an_edit_below_the_clone_blends_it_anew_and_one_above_does_not(pasted):
    stack = LiveStack(pasted)
    bottom = layer_edits.select_layer(pasted, 0)
    recoloured = edits.set_stop_color(bottom, bottom.curves[0].id, "left", 0, (0.0, 1.0, 0.0))
    stack.update(recoloured)
    np.testing.assert_allclose(evaluate_points(stack.composite, GRID), expected(recoloured), atol=1e-9)
    image = stack.clones[pasted.layer.id].image
    above = layer_edits.add_layer(layer_edits.select_layer(recoloured, 1))
    drawn = edits.add_curve(above, recoloured.layers[0].curves[1])
    update = stack.update(drawn)
    assert stack.clones[pasted.layer.id].image is image and set(update.fields) == {(drawn.layer.id, "image")}
    hidden = layer_edits.set_visible(drawn, 0, False)  # the picture below changes: the clone blends with black
    stack.update(hidden)
    assert stack.clones[pasted.layer.id].image is not image
    np.testing.assert_allclose(evaluate_points(stack.composite, GRID), expected(hidden), atol=1e-9)


def test_paste_move_undo_and_redo_give_each_step_exactly(source, pasted):
    history = History(scattered_document(SIZE, seed=8))
    stack = LiveStack(history.document)
    copied = copy_region(source, HEXAGON)
    history.apply(paste_seamless(history.document, copied, Similarity(offset=(5.0, 0.0))), "Paste Seamless")
    stack.update(history.document)
    history.apply(place_clone(history.document, 1, Similarity(0.8, -30.0, (30.0, 20.0))), "Move Clone")
    stack.update(history.document)
    history.apply(layer_edits.set_transform(history.document, 1, hue_rotation(90)), "Colour Adjust")
    steps = [history.document]
    for _ in range(3):
        history.undo()
        steps.append(history.document)
    for _ in range(3):
        history.redo()
        steps.append(history.document)
    for document in steps:
        stack.update(document)
        np.testing.assert_allclose(evaluate_points(stack.composite, GRID), expected(document), atol=1e-9)
    assert steps[3] == steps[0].__class__(SIZE, SIZE, layers=steps[3].layers)  # back to the target alone
    assert history.labels[-3:] == ("Paste Seamless", "Move Clone", "Colour Adjust")


def test_a_clone_layer_holds_no_items_merges_with_nothing_and_takes_no_mask(pasted):
    with pytest.raises(EditRefused, match="clone layer"):
        edits.add_curve(pasted, pasted.layers[0].curves[0])
    with pytest.raises(EditRefused, match="clone layer"):
        layer_edits.merge_down(pasted, 1)
    with pytest.raises(EditRefused, match="clone layer"):
        layer_edits.add_mask(pasted, 1)
    with pytest.raises(EditRefused, match="clone layer"):
        copy_region(pasted, HEXAGON)
    duplicate = layer_edits.duplicate_layer(pasted, 1)
    assert duplicate.layers[2].clone == pasted.layers[1].clone


@pytest.mark.parametrize("region, message", [
    ([[0, 0], [10, 10], [10, 0], [0, 10]], "crosses itself"),
    ([[0, 0], [10, 10]], "three finite"),
    ([[0, 0], [10, 10], [20, 20]], "no area"),
    ([[200, 200], [220, 200], [210, 230]], "wholly outside"),
    ([[0, 0], [1, 0], [np.nan, 1]], "three finite"),
])
def test_bad_regions_are_refused_with_a_message(source, region, message):
    with pytest.raises(EditRefused, match=message):
        copy_region(source, region)


def test_a_region_across_the_canvas_edge_is_cut_to_it_and_a_clone_off_the_canvas_refused(source, pasted):
    copied = copy_region(source, [[-20.0, -20.0], [60.0, -20.0], [60.0, 60.0], [-20.0, 60.0]])
    assert copied.region.min() == 0.0 and copied.region.max() == 60.0
    with pytest.raises(EditRefused, match="wholly outside"):
        place_clone(pasted, 1, Similarity(offset=(500.0, 0.0)))
    with pytest.raises(ValueError, match="not a clone layer"):
        place_clone(pasted, 0, Similarity())


def test_plain_paste_adds_the_curves_meeting_the_region_and_the_points_inside_moved(source):
    target = Document(SIZE, SIZE)
    pasted = paste_curves(target, copy_region(source, HEXAGON), (10.0, -5.0))
    layer = pasted.layer
    assert len(pasted.layers) == 1 and layer.clone is None
    assert 0 < len(layer.curves) < len(source.curves)
    originals = {tuple(np.round(curve.control_points[0], 9)) for curve in source.curves}
    for curve in layer.curves:
        assert tuple(np.round(curve.control_points[0] - [10.0, -5.0], 9)) in originals
    assert [point.position for point in layer.points] == [(70.0, 55.0)]  # the dab inside, moved; not the one outside


def test_a_clone_layer_saved_and_reopened_is_the_same_without_a_solve(tmp_path, pasted):
    session = Session(pasted)
    path = session.save(tmp_path / "clone.fmr")
    opened = load_fmr(path)
    assert opened.document == pasted and opened.composite is not None and opened.notes == ()
    assert dumps_document(pasted).startswith(b'{"format":"fmr-editor document","version":3')
    reopened = Session.open(path)
    assert all(live.origin == "resumed" for live in reopened.live.fields.values())  # the two solved images
    bottom, clone = reopened.document.layers
    assert set(reopened.live.fields) == {(bottom.id, "image"), (clone.id, "source")}
    assert reopened.live.clones[clone.id]._seamless is None  # taken as saved: no boundary solve either
    np.testing.assert_array_equal(reopened.image(48, 48, samples=1), session.image(48, 48, samples=1))
    moved = place_clone(reopened.document, 1, pasted.layer.clone.similarity.moved(5.0, 5.0))
    reopened.apply(lambda _: moved, "Move Clone")  # the reopened clone moves as any other
    np.testing.assert_allclose(evaluate_points(reopened.live.composite, GRID), expected(moved), atol=1e-9)


def test_a_damaged_clone_in_a_file_is_refused_with_its_place(tmp_path, pasted):
    data = json.loads(dumps_document(pasted))
    data["layers"][1]["clone"]["region"] = [[0, 0], [10, 10], [10, 0], [0, 10]]
    with pytest.raises(SchemaError, match=r"layers\[1\]\.clone: .*crosses itself"):
        document_from_data(data)
    data["layers"][1]["clone"]["similarity"]["offset"] = [1e6, 0]
    data["layers"][1]["clone"]["region"] = [list(vertex) for vertex in pasted.layer.clone.region]
    with pytest.raises(SchemaError, match=r"layers\[1\]\.clone: .*wholly outside"):
        document_from_data(data)
    data["layers"][1]["clone"]["similarity"] = {"scale": -1}
    with pytest.raises(SchemaError, match=r"layers\[1\]\.clone: .*positive scale"):
        document_from_data(data)
    data["layers"][1]["clone"]["similarity"], data["layers"][1]["curves"] = {}, data["layers"][0]["curves"]
    with pytest.raises(SchemaError, match=r"layers\[1\]: a clone layer holds no curves"):
        document_from_data(data)
