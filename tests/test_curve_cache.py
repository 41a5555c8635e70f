"""The kept curve segments (engine/curve_cache.py) against ``curve_segments`` from scratch, edit after edit."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import straight_chain, uniform_curve

from fmr_editor.engine.geometry.curve_cache import CurveSegments
from fmr_editor.engine.geometry.discretise import curve_segments
from fmr_editor.io import load_document
from fmr_editor.model import Document, edits

FIELDS = ("p", "q", "jump", "mean", "on_border", "flux", "origin")


def assert_same(cache: CurveSegments, document: Document) -> None:
    got, expected = cache.segments(document), curve_segments(document)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)


def overlapping_document() -> Document:
    """Curves along shared lines: a retracing one, two that lie on it, one elsewhere."""
    return Document(100, 100, (
        uniform_curve(straight_chain([(10, 50), (80, 50), (30, 50), (45, 50)]), 0.9, 0.1),
        uniform_curve(straight_chain([(20, 50), (60, 50)]), 0.2, 0.7),
        uniform_curve(straight_chain([(50, 10), (50, 90)]), 0.5, 0.5),
        uniform_curve(straight_chain([(70, 50), (95, 50), (95, 20)]), 0.3, 0.6),
    ))


def test_edits_give_the_segments_of_a_fresh_discretisation():
    document = overlapping_document()
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    steps = [
        lambda d: edits.move_control_point(d, d.curves[1].id, 3, (75.0, 50.0)),  # slides along the shared line
        lambda d: edits.move_control_point(d, d.curves[1].id, 3, (75.0, 60.0)),  # leaves it
        lambda d: edits.add_curve(d, uniform_curve(straight_chain([(5, 50), (40, 50)]), 0.0, 1.0)),  # on top, last
        lambda d: edits.remove_curves(d, [d.curves[0].id]),  # what it covered comes back
        lambda d: edits.translate(d, (0.0, -10.0), curves=[d.curves[1].id]),
        lambda d: edits.remove_curves(d, [d.curves[len(d.curves) - 1].id]),
    ]
    for step in steps:
        document = step(document)
        assert_same(cache, document)
    assert_same(cache, overlapping_document())  # back to the start: new objects, everything searched


def test_a_real_file_with_retraced_curves(shared_data):
    path = shared_data / "orzan_xml" / "berkbavas" / "flower.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    document = load_document(path)
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    rng = np.random.default_rng(4)
    for _ in range(4):
        k = int(rng.integers(len(document.curves)))
        points = document.curves[k].control_points
        document = edits.move_control_point(document, document.curves[k].id, 0, tuple(points[0] + rng.normal(0, 3, 2)))
        assert_same(cache, document)
    document = edits.remove_curves(document, [document.curves[int(rng.integers(len(document.curves)))].id])
    assert_same(cache, document)
