"""Alpha on colour stops (issue 28): the alpha field against closed forms and the colour field, the composite
against per-pixel composition, edits, merging and files."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from layered import SIZE, reference, translucent_layers, with_alphas
from shapes import circle_points, scattered_document, uniform_curve

from fmr_editor.engine import LiveStack, Role, Settings, build, evaluate_points, rasterise
from fmr_editor.engine.composite import NEGLIGIBLE_WEIGHT
from fmr_editor.io import load_fmr, save_fmr
from fmr_editor.model import ColorStop, DiffusionCurve, DiffusionPoint, Document, EditRefused, Layer, edits, layer_edits
from fmr_editor.model.alpha import alpha_image

PIXELS = 48
LEVEL = 1 / 255


def pixel_centres(pixels: int = PIXELS) -> np.ndarray:
    xs = (np.arange(pixels) + 0.5) * SIZE / pixels
    return np.stack(np.meshgrid(xs, xs), axis=-1).reshape(-1, 2)


def test_a_circle_opaque_inside_and_clear_outside_has_alpha_1_inside_and_0_outside():
    circle = with_alphas(uniform_curve(circle_points(60, 66, 35), left=0.3, right=0.8), left=1.0, right=0.0)
    document = Document(SIZE, SIZE, [circle])
    # At the default order 8 the far field is good to 1.25e-6 here (the colour field of the same circle alike);
    # order 10 to 1.6e-7, so that the check below is of the alpha, not of the truncation.
    stack = LiveStack(document, Settings(order=10))
    points = pixel_centres()
    distance = np.abs(np.hypot(points[:, 0] - 60, points[:, 1] - 66) - 35)
    away = distance >= 3.0  # as tests/test_closed_forms.py
    alpha = evaluate_points(stack.alpha(document.layer), points)[away]
    inside = np.hypot(points[away, 0] - 60, points[away, 1] - 66) < 35
    np.testing.assert_allclose(alpha[inside], 1.0, atol=1e-6)
    np.testing.assert_allclose(alpha[~inside], 0.0, atol=1e-6)
    picture = evaluate_points(stack.composite, points)[away]  # over nothing: its colour inside, black outside
    np.testing.assert_allclose(picture[~inside], 0.0, atol=1e-6)
    assert picture[inside].min() > 0.29


def test_the_alpha_field_is_the_colour_field_of_the_curves_with_the_alphas_as_colours():
    document = translucent_layers()
    layer = document.layers[2]
    stack = LiveStack(document)
    greys = [DiffusionCurve(curve.control_points, tuple(ColorStop(s.position, (s.alpha,) * 3) for s in curve.left),
                            tuple(ColorStop(s.position, (s.alpha,) * 3) for s in curve.right) or
                            (ColorStop(0.0, (1.0, 1.0, 1.0)),))
             for curve in layer.curves]
    expected = rasterise(build(Document(SIZE, SIZE, greys)), PIXELS, PIXELS, samples=1)
    np.testing.assert_allclose(rasterise(stack.alpha(layer), PIXELS, PIXELS, samples=1), expected, atol=1e-9)
    assert expected.std() > 0.1  # the alphas vary


def test_the_composite_with_alpha_equals_per_pixel_composition_of_the_layers():
    document = translucent_layers()
    stack = LiveStack(document)
    assert set(stack.fields) >= {(document.layers[1].id, Role.ALPHA), (document.layers[2].id, Role.ALPHA)}
    assert (document.layers[0].id, Role.ALPHA) not in stack.fields  # an opaque layer solves no alpha
    expected = reference(document, PIXELS, PIXELS)
    error = np.abs(rasterise(stack.composite, PIXELS, PIXELS, samples=1) - expected) / LEVEL
    assert error.mean() <= 1.0 and np.percentile(error, 99) <= 3.0
    assert np.abs(reference(opaque_alphas(document), PIXELS, PIXELS) - expected).max() > 20 * LEVEL  # alpha shows


def opaque_alphas(document: Document) -> Document:
    """``document`` with every stop opaque."""
    def opaque(curve: DiffusionCurve) -> DiffusionCurve:
        return replace(curve, left=tuple(replace(s, alpha=1.0) for s in curve.left),
                       right=tuple(replace(s, alpha=1.0) for s in curve.right))

    return replace(document, layers=tuple(replace(layer, curves=tuple(map(opaque, layer.curves)))
                                          for layer in document.layers))


def test_edits_keep_the_alpha_field_equal_to_a_fresh_build_and_an_opaque_layer_drops_it():
    document = layer_edits.select_layer(translucent_layers(), 2)
    stack = LiveStack(document)
    top = document.layers[2]
    curve = top.curves[0]
    moved = edits.move_control_point(document, curve.id, 1, tuple(curve.control_points[1] + (4.0, -3.0)))
    faded = edits.set_stop_alpha(moved, curve.id, "left", 0, 0.05)
    for step in (moved, faded):
        update = stack.update(step)
        assert (top.id, Role.ALPHA) in update.fields
        fresh = LiveStack(step)
        np.testing.assert_allclose(rasterise(stack.composite, PIXELS, PIXELS, samples=1),
                                   rasterise(fresh.composite, PIXELS, PIXELS, samples=1), atol=0.25 * LEVEL)
    recoloured = edits.set_stop_color(faded, top.curves[1].id, "left", 0, (0.0, 0.0, 1.0))
    assert stack.update(recoloured).fields[top.id, Role.ALPHA].kind in ("colours", "none")  # no new solve
    opaque = opaque_alphas(recoloured)
    stack.update(opaque)
    assert all(key[1] != Role.ALPHA for key in stack.fields)
    np.testing.assert_allclose(rasterise(stack.composite, PIXELS, PIXELS, samples=1),
                               rasterise(LiveStack(opaque).composite, PIXELS, PIXELS, samples=1), atol=0.25 * LEVEL)


def test_the_alpha_image_is_kept_per_layer_and_curve_so_unchanged_curves_stay_the_same_objects():
    document = translucent_layers()
    layer = document.layers[1]
    assert alpha_image(layer) is alpha_image(layer) and alpha_image(document.layers[0]) is None
    moved = edits.move_control_point(layer_edits.select_layer(document, 1), layer.curves[0].id, 1, (10.0, 10.0))
    before, after = alpha_image(layer).curves, alpha_image(moved.layers[1]).curves
    assert after[0] is not before[0] and all(a is b for a, b in zip(after[1:], before[1:]))
    assert [c.id for c in after] == [c.id for c in layer.curves]


def test_merge_down_refuses_a_translucent_upper_layer():
    document = translucent_layers()
    with pytest.raises(EditRefused, match="alpha"):
        layer_edits.merge_down(layer_edits.remove_mask(document, 2), 2)


def test_a_translucent_layer_saves_its_alpha_field_and_reopens_without_a_solve(tmp_path, monkeypatch):
    document = translucent_layers()
    stack = LiveStack(document)
    path = save_fmr(tmp_path / "alpha.fmr", document, stack.composite)
    opened = load_fmr(path)
    assert opened.document == document and opened.composite is not None
    import fmr_editor.engine.live as live

    monkeypatch.setattr(live.LiveRepresentation, "_rebuild", lambda *a, **k: pytest.fail("solved on opening"))
    reopened = LiveStack(opened.document, saved=opened.fields)
    np.testing.assert_array_equal(rasterise(reopened.composite, PIXELS, PIXELS, samples=1),
                                  rasterise(stack.composite, PIXELS, PIXELS, samples=1))


def test_a_file_saved_before_alpha_opens_looking_as_it_did_without_a_solve(monkeypatch):
    from pathlib import Path

    from fmr_editor.session import Session

    made = Path(__file__).parent / "data" / "before_alpha"  # made by the code of that time: see its make.py
    import fmr_editor.engine.live as live

    monkeypatch.setattr(live.LiveRepresentation, "_rebuild", lambda *a, **k: pytest.fail("solved on opening"))
    session = Session.open(made / "layers.fmr")
    assert [layer.name for layer in session.document.layers] == ["Layer 1", "Inverted", "Off", "Paint #e6cc1a"]
    assert not any(layer.translucent for layer in session.document.layers)
    # as then, but for the weights within NEGLIGIBLE_WEIGHT of 0 or 1, which the composition has made 0 or 1 since
    np.testing.assert_allclose(session.image(48, 48, samples=1), np.load(made / "layers.npy"), atol=NEGLIGIBLE_WEIGHT)


def test_a_layer_without_alpha_costs_no_alpha_field():
    document = scattered_document(SIZE)
    stack = LiveStack(document)
    assert set(stack.fields) == {(document.layer.id, Role.IMAGE)} and stack.composite.layers[0].covers


def test_the_alpha_field_takes_its_layer_s_factorisation_and_edits_keep_sharing_it():
    document = translucent_layers()
    layer = document.layers[2]
    stack = LiveStack(document)
    image, alpha = stack.fields[layer.id, Role.IMAGE], stack.fields[layer.id, Role.ALPHA]
    assert (image.factorisations, alpha.factorisations) == (1, 0) and alpha.solver is image.solver
    moved = edits.translate(layer_edits.select_layer(document, 2), (4.0, -3.0),
                            curves=[layer.curves[0].id])  # geometry: an update of the factorisation
    stack.update(moved)
    image, alpha = stack.fields[layer.id, Role.IMAGE], stack.fields[layer.id, Role.ALPHA]
    assert alpha.factorisations == 0 and alpha.solver.base is image.solver.base
    expected = build(Document(SIZE, SIZE, alpha_image(moved.layers[2]).curves))
    np.testing.assert_allclose(rasterise(stack.alpha(moved.layers[2]), PIXELS, PIXELS, samples=1),
                               rasterise(expected, PIXELS, PIXELS, samples=1), atol=1e-6)


def test_an_empty_layer_is_clear_and_a_layer_with_items_or_settings_is_not():
    below = scattered_document(SIZE)
    empty = layer_edits.add_layer(below)
    assert empty.layers[1].empty
    expected = rasterise(LiveStack(below).composite, PIXELS, PIXELS, samples=1)
    np.testing.assert_array_equal(rasterise(LiveStack(empty).composite, PIXELS, PIXELS, samples=1), expected)
    filled, _ = layer_edits.with_fill_layer(below, (1.0, 0.0, 0.0))  # a Paint fill layer: a mask and a colour
    assert not filled.layers[1].empty
    dark = layer_edits.add_layer(below, Layer(points=(DiffusionPoint((60.0, 60.0), 10.0, (1.0, 1.0, 1.0)),)))
    assert np.abs(rasterise(LiveStack(dark).composite, PIXELS, PIXELS, samples=1) - expected).max() > 0.2


def test_an_empty_bottom_layer_is_opaque_black_so_a_new_clear_layer_changes_nothing():
    blank = Document(SIZE, SIZE)  # one empty layer: black, as a new document has always been
    expected = rasterise(build(blank), PIXELS, PIXELS, samples=1, coverage=True)
    np.testing.assert_array_equal(expected, np.tile([0.0, 0.0, 0.0, 1.0], (PIXELS, PIXELS, 1)))
    layered = layer_edits.add_layer(blank)
    shown = rasterise(LiveStack(layered).composite, PIXELS, PIXELS, samples=1, coverage=True)
    np.testing.assert_array_equal(shown, expected)


def test_render_writes_rgba_where_the_picture_is_clear_and_rgb_where_it_is_opaque(tmp_path):
    from cli_runs import run
    from PIL import Image

    disc = with_alphas(uniform_curve(circle_points(64, 60, 30), left=0.4, right=0.4), left=1.0, right=0.0)
    clear, opaque = tmp_path / "clear.fmr", tmp_path / "opaque.fmr"
    save_fmr(clear, Document(SIZE, SIZE, [disc]))
    save_fmr(opaque, Document(SIZE, SIZE, [uniform_curve(circle_points(64, 60, 30), left=0.4, right=0.4)]))
    for path in (clear, opaque):
        assert run("render", str(path), "-o", str(path.with_suffix(".png")))[0] == 0  # 3 x 3 samples a pixel
    with Image.open(clear.with_suffix(".png")) as image:
        assert image.mode == "RGBA"
        pixels = np.asarray(image).astype(int)
    assert tuple(pixels[60, 64]) == (102, 102, 102, 255) and pixels[2, 2, 3] == 0  # 0.4 inside, clear outside
    edge = pixels[(pixels[..., 3] > 0) & (pixels[..., 3] < 255)]  # pixels the circle crosses: partly covered,
    assert len(edge) > 50 and np.abs(edge[:, :3] - 102).max() <= 1  # their colour the disc's (straight alpha)
    with Image.open(opaque.with_suffix(".png")) as image:
        assert image.mode == "RGB"
    flat = tmp_path / "flat.png"
    assert run("render", str(clear), "-o", str(flat), "--background", "#ff8800")[0] == 0
    with Image.open(flat) as image:
        assert image.mode == "RGB" and image.getpixel((2, 2)) == (255, 136, 0) and image.getpixel((64, 60)) == (
            102, 102, 102)
    code, _, said = run("render", str(clear), "-o", str(flat), "--background", "orange")
    assert code == 2 and "six hexadecimal digits" in said
