"""SVG import (issue 29): paths, lines, quadratic and cubic Beziers, arcs, shapes, transforms, viewBox sizes and
fills become the expected curves and colours; bad SVG is refused with one clear message."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

import fmr_editor
from fmr_editor.engine import LiveStack, evaluate_points, rasterise
from fmr_editor.io import DocumentLoadError, load_svg
from fmr_editor.model import Document

RED, BLUE = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)


def svg_file(tmp_path, body: str, size: str = 'width="100" height="80"', name: str = "drawing.svg"):
    path = tmp_path / name
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" {size}>{body}</svg>')
    return path


def test_lines_become_cubic_pieces_with_the_stroke_colour_on_both_sides(tmp_path):
    document = load_svg(svg_file(tmp_path, '<path d="M 10 10 L 50 10 L 50 40" stroke="#ff0000" fill="none"/>'))
    assert (document.width, document.height) == (100, 80) and len(document.curves) == 1
    curve = document.curves[0]
    third = 40 / 3
    np.testing.assert_allclose(curve.control_points, [(10, 10), (10 + third, 10), (10 + 2 * third, 10), (50, 10),
                                                      (50, 20), (50, 30), (50, 40)], atol=1e-12)
    assert [(s.position, s.color, s.alpha) for s in curve.left + curve.right] == [(0.0, RED, 1.0)] * 2


def test_a_quadratic_bezier_is_the_cubic_it_equals_and_a_cubic_is_kept(tmp_path):
    body = '<path d="M 0 0 Q 30 60 60 0 C 70 10 80 10 90 0" stroke="blue" fill="none"/>'
    document = load_svg(svg_file(tmp_path, body))
    curve = document.curves[0]
    t = np.linspace(0, 1, 9)[:, None]
    quadratic = (1 - t) ** 2 * [0, 0] + 2 * (1 - t) * t * [30, 60] + t**2 * [60, 0]
    np.testing.assert_allclose(curve.point_at(t[:, 0]), quadratic, atol=1e-12)
    np.testing.assert_allclose(curve.control_points[3:], [(60, 0), (70, 10), (80, 10), (90, 0)], atol=1e-12)


def test_transforms_and_the_view_box_are_applied(tmp_path):
    body = '<g transform="translate(5,7) scale(2)"><path d="M 0 0 L 10 0" stroke="black" fill="none"/></g>'
    document = load_svg(svg_file(tmp_path, body, size='width="100" height="50" viewBox="0 0 200 100"'))
    assert (document.width, document.height) == (100, 50)  # the SVG's size in pixels; the view box is halved
    np.testing.assert_allclose(document.curves[0].control_points[[0, -1]], [(2.5, 3.5), (12.5, 3.5)], atol=1e-12)
    sized_by_its_box = load_svg(svg_file(tmp_path, body, size='viewBox="0 0 64 48"', name="box.svg"))
    assert (sized_by_its_box.width, sized_by_its_box.height) == (64, 48)


def test_a_filled_circle_is_a_layer_that_covers_exactly_its_inside_and_an_arc_stays_on_its_circle(tmp_path):
    body = ('<circle cx="50" cy="40" r="20" fill="#0000ff"/>'
            '<path d="M 10 70 A 30 30 0 0 1 70 70" stroke="red" fill="none"/>')
    document = load_svg(svg_file(tmp_path, body))
    assert [layer.name for layer in document.layers] == ["Lines", "Circle 1"]  # line art below the shapes
    (arc,), (disc,) = (layer.curves for layer in document.layers)
    s = np.linspace(0, disc.piece_count, 200)
    np.testing.assert_allclose(np.hypot(*(disc.point_at(s) - (50, 40)).T), 20, atol=0.01)
    np.testing.assert_allclose(np.hypot(*(arc.point_at(np.linspace(0, arc.piece_count, 50)) - (40, 70)).T), 30,
                               atol=0.05)
    inside = disc.left if disc.inside_on_left() else disc.right
    outside = disc.right if disc.inside_on_left() else disc.left
    assert [(s.color, s.alpha) for s in inside] == [(BLUE, 1.0)] and [s.alpha for s in outside] == [0.0]
    # Drawn, the disc alone: blue and opaque inside, clear outside.
    only_disc = Document(100, 80, [disc])
    shown = evaluate_points(LiveStack(only_disc).composite, [(50, 40), (52, 45), (95, 5), (5, 75)], coverage=True)
    np.testing.assert_allclose(shown[:2], [(*BLUE, 1.0)] * 2, atol=1e-6)
    np.testing.assert_allclose(shown[2:, 3], 0.0, atol=1e-6)


@pytest.mark.skipif(shutil.which("rsvg-convert") is None,
                    reason="rsvg-convert (Debian's librsvg2-bin, installed by scripts/setup.sh) is missing")
def test_filled_shapes_in_painting_order_look_as_a_third_party_renderer_draws_them(tmp_path):
    body = ('<rect width="160" height="120" fill="#203050"/>'  # a background: along and beyond the border
            '<circle cx="60" cy="55" r="35" fill="#ffcc33"/>'
            '<g transform="rotate(-15 110 80)"><ellipse cx="110" cy="80" rx="40" ry="20" fill="#33aa77"/></g>')
    path = svg_file(tmp_path, body, size='width="160" height="120"')
    document = load_svg(path)
    assert [layer.name for layer in document.layers] == ["Rect 1", "Circle 2", "Ellipse 3"]
    ours = np.round(rasterise(LiveStack(document).composite, samples=3) * 255)
    subprocess.run(["rsvg-convert", str(path), "-o", str(tmp_path / "rsvg.png")], check=True)
    with Image.open(tmp_path / "rsvg.png") as image:
        theirs = np.asarray(image.convert("RGB")).astype(float)
    error = np.abs(ours - theirs).max(axis=2)
    assert np.median(error) == 0 and error.mean() < 0.5  # antialiased edges apart, the same picture
    assert (error > 8).mean() < 0.015  # and the edges are where they are drawn (a rotation lost: 4.6%)


def test_shapes_without_paint_and_text_are_left_out_and_said(tmp_path):
    body = ('<rect x="10" y="10" width="30" height="20" fill="none" stroke="green"/>'
            '<path d="M 0 0 L 5 5" fill="none" stroke="none"/><text x="5" y="5">hi</text>')
    notes = []
    document = load_svg(svg_file(tmp_path, body), notes)
    assert len(document.curves) == 1 and document.curves[0].piece_count == 4  # the rectangle, closed, 4 sides
    assert [layer.name for layer in document.layers] == ["Lines"]  # stroked, not filled: line art
    assert notes == ["not imported (only paths and shapes are): 1 path without stroke or fill, 1 text element"]
    assert fmr_editor.load(svg_file(tmp_path, body)) == document  # the Python API reads SVG by its suffix
    twice = body + '<path d="M 9 9 L 5 5" fill="none" stroke="none"/><text x="9" y="9">ho</text>'
    load_svg(svg_file(tmp_path, twice), notes := [])
    assert notes == ["not imported (only paths and shapes are): 2 paths without stroke or fill, 2 text elements"]


@pytest.mark.parametrize("content, message", [
    ('<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><path d="M 0 0 L 5 5"',
     "not a well-formed XML file"),
    ('<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "aaaaaaaaaa">]>'
     '<svg xmlns="http://www.w3.org/2000/svg">&a;</svg>', "XML entities, which are refused"),
    ('<curve_set image_width="10" image_height="10"/>', "not an SVG file"),
    ('<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><text>hi</text></svg>',
     "no path or shape with a stroke or a fill"),
    ('<svg xmlns="http://www.w3.org/2000/svg" width="100000" height="10"><path d="M 0 0 L 5 5" stroke="red"/></svg>',
     "canvas width must be 1 to"),
    ('<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><path d="M 0 0 L 1e308 1e308 L 5 5" '
     'stroke="red"/></svg>', "control points must be finite"),
    ('<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10">' + "<g>" * 5000
     + '<path d="M 0 0 L 5 5" stroke="red"/>' + "</g>" * 5000 + "</svg>", "nests too deeply"),
    ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="10" height="10">'
     '<g id="a"><use xlink:href="#a"/></g><path d="M 0 0 L 5 5" stroke="red"/></svg>', "nests too deeply"),
])
def test_bad_svg_is_refused_with_one_clear_message(tmp_path, content, message):
    path = tmp_path / "bad.svg"
    path.write_text(content)
    with pytest.raises(DocumentLoadError, match=message) as caught:
        load_svg(path)
    assert str(caught.value).startswith("bad.svg: ")


@pytest.mark.parametrize("rule, inner", [("nonzero", "M 30 30 L 30 70 L 70 70 L 70 30 Z"),  # turning against
                                         ("evenodd", "M 30 30 L 70 30 L 70 70 L 30 70 Z")])  # turning along
def test_a_hole_stays_clear(tmp_path, rule, inner):
    body = f'<path fill-rule="{rule}" fill="#ff0000" d="M 10 10 L 90 10 L 90 90 L 10 90 Z {inner}"/>'
    document = load_svg(svg_file(tmp_path, body, size='width="100" height="100"'))
    assert len(document.layers) == 1 and len(document.curves) == 2
    shown = evaluate_points(LiveStack(document).composite, [(50, 50), (20, 50), (50, 80), (95, 95)], coverage=True)
    np.testing.assert_allclose(shown[:, 3], [0.0, 1.0, 1.0, 0.0], atol=1e-6)  # hole, ring, ring, outside
    np.testing.assert_allclose(shown[1:3, :3], [RED, RED], atol=1e-6)


def test_shapes_apart_share_a_layer_and_overlapping_ones_stack_in_painting_order(tmp_path):
    body = ('<circle id="a" cx="20" cy="20" r="10" fill="red"/><circle id="b" cx="70" cy="20" r="10" fill="blue"/>'
            '<circle id="c" cx="28" cy="20" r="10" fill="#00ff00"/><circle id="d" cx="70" cy="60" r="10" fill="red"/>')
    document = load_svg(svg_file(tmp_path, body))
    assert [layer.name for layer in document.layers] == ["a and 2 more", "c"]  # d overlaps nothing: at the bottom
    assert [len(layer.curves) for layer in document.layers] == [3, 1]
    shown = evaluate_points(LiveStack(document).composite, [(24, 20), (70, 20), (70, 60), (45, 45)], coverage=True)
    # Shapes of other colours in one layer reach each other through its far field: a quarter of a level here.
    np.testing.assert_allclose(shown, [(0, 1, 0, 1), (*BLUE, 1), (*RED, 1), (0, 0, 0, 0)], atol=1e-3)


def test_too_many_curves_are_refused_while_importing(tmp_path, monkeypatch):
    from fmr_editor.model import limits

    monkeypatch.setattr(limits, "MAX_CURVES", 3)
    body = "".join(f'<path d="M 0 {y} L 50 {y}" stroke="red" fill="none"/>' for y in range(10, 60, 10))
    with pytest.raises(DocumentLoadError, match="drawing.svg: more than 3 curves to import"):
        load_svg(svg_file(tmp_path, body))
