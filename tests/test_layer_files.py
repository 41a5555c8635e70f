"""Layered documents in files and on the command line.

Checks
------
* A ``.fmr`` written before layers (``files/version1.fmr``, saved by the code
  of that time and kept) opens as one plain layer with its representation, no
  solve, and renders as a fresh solution of its document carried with every
  term through the passes (as that code built).
* A layered document saved and reopened is the same document, opens without a
  solve, and gives the same pixels.
* ``fmr-editor compose`` writes what the reference composition gives;
  ``fmr-editor render`` renders it; bad input gives one clear line, exit 2 and
  no file.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run
from layered import SIZE, reference, sharp_mask, soft_mask, three_layers
from PIL import Image
from shapes import circle_points, scattered_document

from fmr_editor.engine import LiveStack, Settings, build, rasterise
from fmr_editor.engine.cells import Cells
from fmr_editor.io import load_fmr, open_live, save_fmr
from fmr_editor.io.png import to_rgb8
from fmr_editor.model import Document, layer_edits
from fmr_editor.model.color_transform import hue_rotation
from fmr_editor.session import Session

VERSION_1 = Path(__file__).parent / "files" / "version1.fmr"
PIXELS = 32


def test_a_version_1_file_opens_as_one_layer_without_a_solve():
    opened = load_fmr(VERSION_1)
    document = opened.document
    assert len(document.layers) == 1 and document.is_flat
    assert len(document.curves) == 2 and len(document.points) == 2
    assert opened.representation is not None and opened.notes == ()
    live = open_live(VERSION_1)
    assert [field.origin for field in live.fields.values()] == ["resumed"]
    settings = opened.settings or Settings()
    fresh = build(document, settings)
    # The file's expansions carry every term through every translation, as builds then did; builds now carry
    # the terms their pixels need (fmm/orders.py, held to the direct sum in test_passes), so the file is held to
    # the fresh solution propagated the old way.
    every_term = Cells.build(fresh.segments, fresh.lattice, settings.propagation_order)
    np.testing.assert_allclose(rasterise(opened.representation, PIXELS, samples=1),
                               rasterise(replace(fresh, local=every_term.local), PIXELS, samples=1), rtol=0, atol=1e-9)


def test_a_layered_document_saved_and_reopened_is_the_same_without_a_solve(tmp_path):
    session = Session(three_layers())
    session.apply(lambda d: layer_edits.set_visible(d, 0, False), "Hide Layer")
    path = session.save(tmp_path / "layers.fmr")
    opened = load_fmr(path)
    assert opened.document == session.document
    assert opened.composite is not None  # every representation it needs is in the file
    reopened = Session.open(path)
    assert all(live.origin == "resumed" for live in reopened.live.fields.values())
    assert len(reopened.live.fields) == 5  # three images, two masks
    np.testing.assert_array_equal(reopened.image(PIXELS, PIXELS, samples=1), session.image(PIXELS, PIXELS, samples=1))


# -- the command line --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("compose")
    documents = three_layers()
    bottom, top = (Document(SIZE, SIZE, layer.curves) for layer in (documents.layers[0], documents.layers[2]))
    paths = {"bottom": folder / "bottom.fmr", "top": folder / "top.fmr", "mask": folder / "mask.fmr",
             "small": folder / "small.fmr"}
    settings = Settings()
    save_fmr(paths["bottom"], bottom, build(bottom, settings), settings=settings)  # with a representation
    save_fmr(paths["top"], top)  # without: compose solves it
    mask = sharp_mask()
    save_fmr(paths["mask"], Document(SIZE, SIZE, mask.curves, soft_mask().points))
    save_fmr(paths["small"], scattered_document(64))
    return paths


def orzan_disc(cx: float, cy: float, radius: float) -> bytes:
    """An Orzan CurveSetXML file of one closed circle, orange inside (its left) and opaque there (A=255), clear
    outside (A=0): Orzan's x is the row and y the column, B red and R blue."""
    points = "".join(f'<control_point x="{float(y)!r}" y="{float(x)!r}" />' for x, y in circle_points(cx, cy, radius))
    inside = '<left_color B="255" G="128" R="0" A="255" globalID="0" />'
    outside = '<right_color B="255" G="128" R="0" A="0" globalID="0" />'
    return (f'<!DOCTYPE CurveSetXML>\n<curve_set image_width="{SIZE}" image_height="{SIZE}"><curve>'
            f"<control_points_set>{points}</control_points_set><left_colors_set>{inside}</left_colors_set>"
            f"<right_colors_set>{outside}</right_colors_set></curve></curve_set>").encode()


def test_compose_with_an_xml_whose_stops_carry_alpha_matches_per_pixel_composition(tmp_path, inputs):
    top = tmp_path / "disc.xml"
    top.write_bytes(orzan_disc(70.0, 60.0, 30.0))
    out, png = tmp_path / "out.fmr", tmp_path / "out.png"
    code, _, said = run("compose", str(inputs["bottom"]), str(top), "-o", str(out), "--opacity", "0.9")
    assert code == 0, said
    document = load_fmr(out).document
    assert document.layers[1].translucent and [s.alpha for s in document.layers[1].curves[0].right] == [0.0]
    assert run("render", str(out), "-o", str(png), "--width", str(PIXELS), "--samples", "1")[0] == 0
    expected = to_rgb8(reference(document, PIXELS, PIXELS)).astype(int)
    got = np.asarray(Image.open(png).convert("RGB")).astype(int)
    assert np.abs(got - expected).max() <= 1
    corner = to_rgb8(reference(Document(SIZE, SIZE, document.layers[0].curves), PIXELS, PIXELS))[0, 0].astype(int)
    assert np.abs(got[0, 0] - corner).max() <= 1  # clear outside the disc: the bottom shows


def test_compose_writes_the_reference_composition_and_render_draws_it(tmp_path, inputs):
    out = tmp_path / "out.fmr"
    code, printed, _ = run("compose", str(inputs["bottom"]), str(inputs["top"]), "-o", str(out),
                           "--mask", str(inputs["mask"]), "--opacity", "0.8", "--hue", "150")
    assert code == 0 and "2 layers" in printed
    document = load_fmr(out).document
    top = document.layers[1]
    assert [layer.name for layer in document.layers] == ["Bottom", "Top"] and top.opacity == 0.8
    assert top.transform == hue_rotation(150) and top.mask.base == 0.0 and len(top.mask.points) == 30
    png = tmp_path / "out.png"
    assert run("render", str(out), "-o", str(png), "--width", str(PIXELS), "--samples", "1")[0] == 0
    expected = to_rgb8(reference(document, PIXELS, PIXELS)).astype(int)
    got = np.asarray(Image.open(png).convert("RGB")).astype(int)
    assert np.abs(got - expected).max() <= 1
    without_mask = to_rgb8(reference(layer_edits.remove_mask(document, 1), PIXELS, PIXELS)).astype(int)
    assert np.abs(without_mask - expected).max() > 20  # the mask shows


@pytest.mark.parametrize("extra, message", [
    (("--opacity", "1.5"), "must lie between 0 and 1, got 1.5"),
    (("--opacity", "nan"), "must be a finite number, got nan"),
    (("--hue", "inf"), "must be a finite number"),
    (("--mask", "missing.fmr"), "cannot open missing.fmr: file not found"),
    (("--mask", "{small}"), "the mask canvas is 64x64, the bottom's 128x128"),
])
def test_compose_refuses_bad_input_with_one_line_and_writes_nothing(tmp_path, inputs, extra, message):
    out = tmp_path / "out.fmr"
    extra = tuple(item.format(small=inputs["small"]) for item in extra)
    code, _, err = run("compose", str(inputs["bottom"]), str(inputs["top"]), "-o", str(out), *extra)
    assert code == 2 and message in err.strip().splitlines()[-1]
    assert "Traceback" not in err and not out.exists()


def test_compose_takes_only_representations_built_with_the_same_settings(tmp_path, inputs):
    other = Settings(propagation_order=10)
    document = load_fmr(inputs["top"]).document
    top = tmp_path / "top_p10.fmr"
    save_fmr(top, document, build(document, other), settings=other)
    out = tmp_path / "out.fmr"
    code, _, err = run("compose", str(inputs["bottom"]), str(top), "-o", str(out))
    assert code == 0, err
    composed = load_fmr(out)
    assert composed.settings == Settings() and composed.composite is not None  # the top layer solved again


def test_compose_refuses_documents_of_different_sizes(tmp_path, inputs):
    out = tmp_path / "out.fmr"
    code, _, err = run("compose", str(inputs["small"]), str(inputs["top"]), "-o", str(out))
    assert code == 2 and err.count("\n") == 1 and "the top canvas is 128x128, the bottom's 64x64" in err
    assert not out.exists()


def test_a_composed_file_opens_ready_for_a_session(tmp_path, inputs):
    out = tmp_path / "out.fmr"
    assert run("compose", str(inputs["bottom"]), str(inputs["top"]), "-o", str(out), "--hue", "90")[0] == 0
    session = Session.open(out)
    assert all(live.origin == "resumed" for live in session.live.fields.values())
    stack = LiveStack(session.document)
    np.testing.assert_allclose(session.image(PIXELS, samples=1), rasterise(stack.composite, PIXELS, samples=1),
                               atol=1e-9)
