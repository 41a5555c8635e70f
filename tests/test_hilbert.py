"""The Hilbert benchmark document of bench/hilbert.py: closed, simple, inside the canvas, renderable."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from fmr_editor.engine import build, rasterise

_PATH = Path(__file__).resolve().parents[1] / "bench" / "hilbert.py"
_spec = importlib.util.spec_from_file_location("bench_hilbert", _PATH)
hilbert = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hilbert)


def _curve(iteration: int, size: int = 256):
    document = hilbert.hilbert_document(iteration, size)
    assert len(document.curves) == 1
    return document, document.curves[0]


@pytest.mark.parametrize("iteration", [1, 2, 3, 4])
def test_closed_with_documented_piece_count(iteration):
    _, curve = _curve(iteration)
    points = curve.control_points
    assert np.array_equal(points[-1], points[0])
    assert curve.piece_count == hilbert.piece_count(iteration) == 2 * 4**iteration
    # straight pieces: inner control points at 1/3 and 2/3 of the chord
    pieces = curve.pieces()
    chord = pieces[:, 3] - pieces[:, 0]
    assert np.allclose(pieces[:, 1], pieces[:, 0] + chord / 3)
    assert np.allclose(pieces[:, 2], pieces[:, 0] + 2 * chord / 3)


def test_paper_iterations_map_to_table_rows():
    counts = [hilbert.piece_count(i) for i in hilbert.PAPER_ITERATIONS]
    assert counts == [2_048, 8_192, 32_768, 131_072, 524_288]


@pytest.mark.parametrize("iteration", [1, 2, 3, 4])
def test_loop_is_simple(iteration):
    _, curve = _curve(iteration)
    ends = curve.control_points[0::3]
    assert LineString(ends).is_simple
    polygon = Polygon(ends[:-1])
    assert polygon.is_valid
    assert polygon.area > 0


@pytest.mark.parametrize("iteration", [1, 2, 3, 4])
def test_inside_canvas_with_margin(iteration):
    size = 256
    _, curve = _curve(iteration, size)
    margin = hilbert.margin_of(size)
    points = curve.control_points
    assert points.min() >= margin - 1e-9
    assert points.max() <= size - margin + 1e-9
    # the loop spans the canvas up to its margin
    assert np.isclose(points.min(), margin) and np.isclose(points.max(), size - margin)


def test_colours_vary_and_close_up():
    _, curve = _curve(3)
    k = curve.piece_count
    s = np.array([0.0, k / 3, k / 2, float(k)])
    left, right = curve.left_colors_at(s), curve.right_colors_at(s)
    assert np.allclose(left[0], left[-1]) and np.allclose(right[0], right[-1])
    assert np.ptp(left, axis=0).max() > 0.3
    assert np.abs(left - right).max(axis=1).min() > 0.1  # the jump never vanishes


def test_each_piece_is_one_segment():
    from fmr_editor.engine.geometry.discretise import curve_segments

    size = 128
    document = hilbert.hilbert_document(3, size)
    settings = hilbert.hilbert_settings(size)
    segments = curve_segments(document, settings.tolerance, settings.max_length)
    assert len(segments) == hilbert.piece_count(3)


def test_builds_and_renders_within_colour_range():
    size = 64
    document = hilbert.hilbert_document(2, size)
    image = rasterise(build(document, hilbert.hilbert_settings(size)), size, size, samples=1)
    assert image.shape == (size, size, 3)
    assert np.isfinite(image).all()
    assert image.min() >= -0.05 and image.max() <= 1.05
