"""SVG export (issue 29): a third-party renderer shows what the PNG export shows, and the hidden paths parse
back, through a real SVG parser, to the document's curves, stops, points and layers."""

from __future__ import annotations

import json
import shutil
import subprocess
from dataclasses import replace

import numpy as np
import pytest
import svgelements
from cli_runs import run
from layered import SIZE, translucent_layers
from PIL import Image

from fmr_editor.io import save_fmr
from fmr_editor.io.svg_export import save_svg
from fmr_editor.model import Document


@pytest.fixture(scope="module")
def layered(tmp_path_factory):
    """Three layers with alpha, masks and points, saved; without the opaque bottom one, so that the picture is
    clear in places."""
    path = tmp_path_factory.mktemp("svg") / "layers.fmr"
    document = translucent_layers()
    document = replace(document, layers=document.layers[1:], active=0)
    save_fmr(path, document)
    return document, path


def pixels(path) -> np.ndarray:
    with Image.open(path) as image:
        return np.asarray(image.convert("RGBA")).astype(int)


@pytest.mark.skipif(shutil.which("rsvg-convert") is None,
                    reason="rsvg-convert (Debian's librsvg2-bin, installed by scripts/setup.sh) is missing")
@pytest.mark.parametrize("width", [None, 96])
def test_a_third_party_renderer_shows_the_svg_as_the_png_export(layered, tmp_path, width):
    _, source = layered
    size = [] if width is None else ["--width", str(width)]
    assert run("render", str(source), "-o", str(tmp_path / "out.svg"), *size)[0] == 0
    assert run("render", str(source), "-o", str(tmp_path / "out.png"), *size)[0] == 0
    subprocess.run(["rsvg-convert", str(tmp_path / "out.svg"), "-o", str(tmp_path / "rsvg.png")], check=True)
    shown, exported = pixels(tmp_path / "rsvg.png"), pixels(tmp_path / "out.png")
    assert shown.shape == exported.shape == ((width or SIZE), (width or SIZE), 4)
    assert exported[..., 3].min() < 255  # the picture is not opaque everywhere: RGBA through both
    assert np.abs(shown[..., 3] - exported[..., 3]).max() <= 1
    # As any background sees them: premultiplied (a renderer's straight colour where alpha is a few levels is
    # that colour's 8 bits divided by the alpha's: meaningless).
    over_black = [image[..., :3] * image[..., 3:] / 255.0 for image in (shown, exported)]
    assert np.abs(over_black[0] - over_black[1]).max() <= 1.0


def test_the_hidden_paths_parse_back_to_the_curves_points_and_layers(layered, tmp_path):
    document, _ = layered
    image = np.zeros((SIZE, SIZE, 4))  # one pixel a document pixel: the parser maps the viewBox onto itself
    path = save_svg(document, image, tmp_path / "vectors.svg")
    svg = svgelements.SVG.parse(str(path), parse_display_none=True)
    box = svg.viewbox
    assert (svg.width, svg.height) == (SIZE, SIZE) and (box.x, box.y, box.width, box.height) == (0, 0, SIZE, SIZE)
    groups = [g for g in svg.elements() if isinstance(g, svgelements.Group) and (g.id or "").startswith("layer-")]
    assert [g.values["data-name"] for g in groups] == [layer.name for layer in document.layers]
    paths = [e for e in svg.elements() if isinstance(e, svgelements.Path)]
    curves = [c for layer in document.layers for c in layer.curves + (layer.mask.curves if layer.mask else ())]
    assert len(paths) == len(curves) and curves
    for element, curve in zip(paths, curves, strict=True):
        pieces = [s for s in element if isinstance(s, svgelements.CubicBezier)]
        parsed = [pieces[0].start] + [p for s in pieces for p in (s.control1, s.control2, s.end)]
        np.testing.assert_array_equal([(p.x, p.y) for p in parsed], curve.control_points)  # exactly
        stops = json.loads(element.values["data-left"]), json.loads(element.values["data-right"])
        for side, parsed_stops in zip((curve.left, curve.right), stops, strict=True):
            assert [(s.position, s.color, s.alpha) for s in side] == [(p, tuple(c), a) for p, c, a in parsed_stops]
    circles = [e for e in svg.elements() if isinstance(e, svgelements.Circle)]
    points = [p for layer in document.layers for p in layer.points + (layer.mask.points if layer.mask else ())]
    assert len(circles) == len(points) and points
    for circle, point in zip(circles, points, strict=True):
        assert (circle.cx, circle.cy, circle.rx) == (*point.position, point.radius)
        assert tuple(json.loads(circle.values["data-color"])) == point.color


def test_nothing_of_the_vectors_shows_and_the_file_is_well_formed_xml(tmp_path):
    import defusedxml.ElementTree as SafeTree

    document = Document(32, 16)
    path = save_svg(document, np.ones((16, 32, 3)), tmp_path / "blank.svg")
    root = SafeTree.parse(path).getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg" and root.get("version") == "1.1"
    hidden = root.find("{http://www.w3.org/2000/svg}g")
    assert hidden.get("display") == "none"
    assert not any(e for e in svgelements.SVG.parse(str(path)).elements() if isinstance(e, svgelements.Path))
