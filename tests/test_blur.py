"""Blur along curves (issue 29, item 1): the blur field against the colour field, the blurred picture against
the normal CDF, the fast blur against the plain per-pixel sum, on real files at two zooms."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.special import ndtr
from shapes import straight_chain

from fmr_editor import render_image
from fmr_editor.engine import LiveStack, build, rasterise
from fmr_editor.engine.blur import blurred, blurred_reference
from fmr_editor.model import BlurStop, ColorStop, DiffusionCurve, Document, Layer, edits, layer_edits

LEVEL = 1 / 255
WHITE, BLACK = (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)


def edge(blur: tuple[BlurStop, ...], width: int = 128, height: int = 64) -> Document:
    """A straight curve down the middle of the canvas: black to its left as seen, white to its right."""
    curve = DiffusionCurve(straight_chain([(width / 2, -8.0), (width / 2, height + 8.0)]),
                           left=(ColorStop(0.0, WHITE),), right=(ColorStop(0.0, BLACK),), blur=blur)
    return Document(width, height, [curve])  # going down, its left is +x: white on the right of the picture


@pytest.mark.parametrize("s", [1.5, 4.0])
def test_a_straight_edge_under_a_constant_blur_is_the_normal_cdf(s):
    document = edge((BlurStop(0.0, s),))
    image = render_image(document, samples=3, blur=True)
    x = np.arange(document.width) + 0.5
    expected = ndtr((x - document.width / 2) / s)
    rows = image[8:-8, :, 0]  # away from the top and bottom rows
    assert np.abs(rows - expected).max() <= LEVEL
    assert np.abs(image[..., 0] - image[..., 2]).max() < 1e-6  # grey
    sharp = render_image(edge(()), samples=3)
    assert np.abs(sharp[8:-8, :, 0] - expected).max() > 0.3  # the blur made the difference


def test_render_blurs_unless_asked_not_to(tmp_path):
    from cli_runs import run
    from PIL import Image

    from fmr_editor.io import save_fmr

    path = save_fmr(tmp_path / "edge.fmr", edge((BlurStop(0.0, 4.0),)))
    for flags, name in ((("--no-blur",), "sharp.png"), ((), "soft.png")):
        assert run("render", str(path), "-o", str(tmp_path / name), *flags)[0] == 0
    with Image.open(tmp_path / "sharp.png") as sharp, Image.open(tmp_path / "soft.png") as soft:
        rows = [np.asarray(image)[32, :, 0].astype(int) for image in (sharp, soft)]
    expected = np.round(ndtr((np.arange(128) + 0.5 - 64) / 4.0) * 255)
    assert np.abs(rows[1] - expected).max() <= 1 and np.abs(rows[0] - expected).max() > 60


def test_zero_blur_is_today_s_render_bit_for_bit():
    document = edge((BlurStop(0.0, 0.0), BlurStop(1.0, 0.0)))
    np.testing.assert_array_equal(render_image(document, 64, 32, blur=True), render_image(document, 64, 32))


def test_the_blur_field_is_the_colour_field_of_the_blur_values():
    curve = DiffusionCurve(straight_chain([(10.0, 50.0), (60.0, 20.0), (118.0, 60.0)]),
                           left=(ColorStop(0.0, WHITE),), blur=(BlurStop(0.0, 1.0), BlurStop(2.0, 7.0)))
    ring = DiffusionCurve(straight_chain([(30.0, 30.0), (50.0, 30.0), (50.0, 50.0), (30.0, 50.0), (30.0, 30.0)]),
                          left=(ColorStop(0.0, BLACK),))  # no blur stops: sharp
    document = Document(128, 64, [curve, ring])
    stack = LiveStack(document, blur=True)
    field = rasterise(stack.blur(document.layer), 64, 32, samples=1)
    greys = [replace(curve, left=(ColorStop(0.0, (1.0,) * 3), ColorStop(2.0, (7.0,) * 3)),
                     right=(ColorStop(0.0, (1.0,) * 3), ColorStop(2.0, (7.0,) * 3)), blur=()),
             replace(ring, left=(ColorStop(0.0, BLACK),), right=(ColorStop(0.0, BLACK),))]
    expected = rasterise(build(Document(128, 64, greys)), 64, 32, samples=1)
    np.testing.assert_allclose(field, expected, atol=1e-9)
    assert stack.fields[document.layer.id, "image"].factorisations == 1
    assert stack.fields[document.layer.id, "blur"].factorisations == 0  # the image's factorisation, shared
    moved = edits.translate(document, (3.0, 2.0), curves=[curve.id])
    stack.update(moved)
    expected = rasterise(build(Document(128, 64, [replace(greys[0], control_points=moved.curves[0].control_points),
                                                  greys[1]])), 64, 32, samples=1)
    np.testing.assert_allclose(rasterise(stack.blur(moved.layer), 64, 32, samples=1), expected, atol=1e-6)
    stack.update(layer_edits.add_layer(moved, Layer((ring,), name="other")))
    stack.update(layer_edits.remove_layer(layer_edits.select_layer(stack.document, 0), 0))
    assert not any(role == "blur" for _, role in stack.fields)  # the removed layer's blur field goes with it


def test_the_fast_blur_follows_the_plain_sum_where_the_blur_varies():
    """A picture as diffusion makes them (smooth, with hard edges along curves, here inside pixels) under a
    blur from sharp to 6 px.  Below 2 px the two differ at the edges by up to 4 levels: the fast blur sees
    the raster's pixel means, which cannot say where in its pixel an edge lies."""
    rng = np.random.default_rng(5)
    fine, height, width = 4, 48, 40
    picture = blurred(rng.random((height * fine, width * fine, 3)), np.full((height * fine, width * fine), 8.0))
    yy, xx = np.mgrid[0 : height * fine, 0 : width * fine]
    picture[xx > 61] = picture[xx > 61] * 0.3 + 0.7  # an edge a quarter into a pixel
    picture[yy > 0.6 * xx + 40] *= 0.2  # a slanted one
    y, x = np.mgrid[0:height, 0:width]
    sigma = 0.05 + 6.0 * (x / width) * (y / height)
    image = picture.reshape(height, fine, width, fine, 3).mean(axis=(1, 3))  # what the raster gives
    error = np.abs(blurred(image, sigma) - blurred_reference(picture, sigma))
    assert error.mean() <= 0.25 * LEVEL
    assert error[sigma >= 2.0].max() <= 0.5 * LEVEL
    assert error[sigma < 0.1].max() < 1e-3  # sharp: the pixel means


@pytest.mark.parametrize("name", ["lady_bug", "glass_droplet_blur", "fruits"])
def test_the_fast_blur_is_within_a_level_of_the_plain_sum_on_real_files_at_two_zooms(shared_data, name):
    """At 1:1 and 2:1, over the 24 x 24 pixels about the most blurred point away from the border: the fast blur
    of the pixel means (what the raster gives, 4 x 4 samples a pixel) against the plain sum over the samples."""
    from fmr_editor.engine import evaluate_points
    from fmr_editor.io import load_document

    document = load_document(shared_data / "orzan_xml" / "berkbavas" / f"{name}.xml")
    stack = LiveStack(document, blur=True)
    blur = stack.blur(document.layer)
    field = np.maximum(rasterise(blur, samples=1)[..., 0], 0.0)
    fine, size = 4, 24
    reach = math.ceil(4 * field.max()) + 2 + size  # the blur's reach and the crop from the border
    inner = field[reach:-reach, reach:-reach]
    cy, cx = np.array(np.unravel_index(np.argmax(inner), inner.shape)) + reach  # in document pixels
    for zoom in (1.0, 2.0):
        width, height = round(document.width * zoom), round(document.height * zoom)
        sigma = np.maximum(rasterise(blur, width, height, samples=1)[..., 0], 0.0) * zoom
        margin = math.ceil(4 * sigma.max()) + 2
        top, left = round(cy * zoom) - size // 2 - margin, round(cx * zoom) - size // 2 - margin
        span = size + 2 * margin
        ticks = (np.arange(span * fine) + 0.5) / fine  # output pixels from the corner of the span
        points = np.stack(np.meshgrid(left + ticks, top + ticks), axis=-1).reshape(-1, 2) / zoom
        picture = evaluate_points(stack.composite, points).reshape(span * fine, span * fine, 3)
        around = sigma[top : top + span, left : left + span]
        fast = blurred(picture.reshape(span, fine, span, fine, 3).mean(axis=(1, 3)), around)
        inside = (slice(margin, margin + size),) * 2
        reference = blurred_reference(picture, around[inside], margin=margin)
        assert around[inside].max() >= 2.0 * zoom  # blurred indeed
        error = np.abs(fast[inside] - reference)
        assert error.mean() <= 0.25 * LEVEL, (zoom, error.mean())
        assert error[around[inside] >= 2.0].max() <= LEVEL, zoom  # below: the pixel means, as above
    assert stack.fields[document.layer.id, "blur"].factorisations == 0  # the image's segments: its factorisation


def test_the_window_picture_at_the_canvas_s_own_view_is_the_raster():
    """``window_picture`` (the CPU side of the canvas) and ``rasterise`` blur alike where their pixels are the
    same: the canvas's pixels at 1:1 from its corner, reflected at its border either way."""
    from layered import blurred_layers

    from fmr_editor.engine.blur import window_picture

    picture = LiveStack(blurred_layers(), blur=True).composite
    raster = rasterise(picture, samples=1, coverage=True)
    window = window_picture(picture, (0.0, 0.0), 1.0, picture.width, picture.height)
    np.testing.assert_allclose(window, raster, atol=1e-6)
    sharp = rasterise(picture.sharp, samples=1, coverage=True)
    assert np.abs(window - sharp).max() > 0.1  # blurred indeed


def test_the_blur_plan_covers_every_pixel_s_bracket_with_whole_tiles():
    """``render.blur_filter``'s plan, against the brackets of every pixel found plainly: each tile's range holds
    its pixels' brackets, the blend rectangles of a bracket hold all its pixels, and ``column_runs`` gives
    back exactly the tiles asked for."""
    from fmr_editor.engine.blur import levels
    from fmr_editor.render.blur_filter import TILE, BlurPlan, column_runs

    rng = np.random.default_rng(4)
    height, width = 70, 90
    y, x = np.mgrid[0:height, 0:width]
    field = (np.sin(x / 9.0) * np.cos(y / 7.0) * 4.0 + rng.normal(0, 0.05, (height, width))).astype(np.float32)
    scale = 1.5
    sigma = np.clip(field.astype(np.float64) * scale, 0.0, None)
    plan = BlurPlan.of(field, scale, float(sigma.max()) + 2.0)  # the field's largest value: beyond the window's
    assert plan.ladder == levels(float(sigma.max()) + 2.0)
    bracket = np.searchsorted(plan.ladder, sigma, side="left")
    for k in range(len(plan.ladder)):
        covered = np.zeros((height, width), bool)
        for x0, y0, x1, y1 in plan.blend_rects(k):
            covered[y0:y1, x0:x1] = True
        assert covered[bracket == k].all()
    for row, column in np.ndindex(plan.lowest.shape):
        tile = bracket[row * TILE : (row + 1) * TILE, column * TILE : (column + 1) * TILE]
        assert plan.lowest[row, column] <= tile.min() and tile.max() <= plan.highest[row, column]
    wanted = rng.random((5, 7)) < 0.4
    drawn = np.zeros_like(wanted)
    for x0, y0, x1, y1 in column_runs(wanted):
        assert not drawn[y0:y1, x0:x1].any()  # no tile twice
        drawn[y0:y1, x0:x1] = True
    np.testing.assert_array_equal(drawn, wanted)


def test_a_document_saved_with_its_blur_shown_opens_with_its_blur_field_solving_nothing(tmp_path):
    from fmr_editor.io import load_fmr, save_fmr

    document = edge((BlurStop(0.0, 1.0), BlurStop(1.0, 5.0)))
    stack = LiveStack(document, blur=True)
    saved = load_fmr(save_fmr(tmp_path / "soft.fmr", document, stack.composite))
    assert saved.composite.layers[0].blur is not None
    opened = LiveStack(saved.document, saved=saved.fields)
    assert opened.composite.layers[0].blur is None  # kept until the blur is shown
    opened.set_blur(True)
    assert {live.origin for live in opened.fields.values()} == {"resumed"}
    np.testing.assert_array_equal(rasterise(opened.composite, samples=1), rasterise(stack.composite, samples=1))
    sharp = load_fmr(save_fmr(tmp_path / "sharp.fmr", document, LiveStack(document).composite))
    assert sharp.composite.layers[0].blur is None  # saved while the blur was not shown: solved when shown


def test_the_python_api_blurs_unless_asked_not_to():
    from fmr_editor.session import Session

    document = edge((BlurStop(0.0, 4.0),))
    session = Session(document)
    np.testing.assert_allclose(session.image(samples=1, blur=False), render_image(document, samples=1, blur=False),
                               atol=1e-6)
    assert not session.live.show_blur  # nothing solved for the blur yet
    soft = session.image(samples=1)
    np.testing.assert_allclose(soft, render_image(document, samples=1), atol=1e-6)
    assert np.abs(soft - session.image(samples=1, blur=False)).max() > 0.3
    moved = edits.translate(document, (5.0, 0.0), curves=[document.curves[0].id])
    session.apply(moved, "Move")  # the blur field follows the edit
    np.testing.assert_allclose(session.image(samples=1), render_image(moved, samples=1), atol=1e-6)


def test_a_blur_beyond_the_largest_is_drawn_at_the_largest():
    """The documented clamp (``LARGEST`` output pixels, which bounds the margin a canvas window needs)."""
    from fmr_editor.engine.blur import LARGEST

    rng = np.random.default_rng(8)
    image = rng.random((40, 50, 3))
    np.testing.assert_array_equal(blurred(image, np.full((40, 50), 3 * LARGEST)),
                                  blurred(image, np.full((40, 50), LARGEST)))


def test_a_blur_value_out_of_range_is_refused_with_one_message(tmp_path):
    """A blur value must be finite and at most ``MAX_BLUR`` px: a file holding another (its blur field would
    overflow the solve) gives the load error, naming the curve."""
    import zipfile

    from fmr_editor.io import DocumentLoadError, load_document, save_fmr
    from fmr_editor.model.limits import MAX_BLUR

    with pytest.raises(ValueError, match="blur values must be finite"):
        edge((BlurStop(0.0, float("nan")),))
    with pytest.raises(ValueError, match="blur values must be finite"):
        edge((BlurStop(0.0, 2 * MAX_BLUR),))
    good = save_fmr(tmp_path / "good.fmr", edge((BlurStop(0.0, 5.0),)))
    with zipfile.ZipFile(good) as archive:
        mimetype, text = archive.read("mimetype"), archive.read("document.json").decode()
    bad = tmp_path / "bad.fmr"
    with zipfile.ZipFile(bad, "w") as archive:
        archive.writestr("mimetype", mimetype, compress_type=zipfile.ZIP_STORED)
        archive.writestr("document.json", text.replace('"blur":5.0', '"blur":1e9'))
    with pytest.raises(DocumentLoadError, match=r"curves\[0\]: blur values must be finite"):
        load_document(bad)
