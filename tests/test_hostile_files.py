"""Each finding of the fuzzing campaign of issue 16, kept as a small file under ``tests/data/hostile``.

``tests/data/hostile/make.py`` made the files; the large inputs are made here.  A hostile input gives
the documented error with one short message, or opens and renders finite colours; either way no work
grows with a coordinate, a repetition or a declared size (checked by what is never called or allocated,
not by the clock).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely
from cli_runs import run
from shapes import circle_points

from fmr_editor.engine import build, evaluate_points, rasterise
from fmr_editor.engine.geometry import curve_cache
from fmr_editor.engine.geometry.discretise import curve_segments
from fmr_editor.engine.geometry.overlaps import COINCIDENT_DISTANCE
from fmr_editor.engine.memory import affordable_levels, check_build_memory, check_image_memory
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.io import DocumentLoadError, load_document, load_fmr, orzan
from fmr_editor.io.document_json import SchemaError, dumps_document, loads_document
from fmr_editor.model import ColorStop, DiffusionCurve, Document, limits
from fmr_editor.model.limits import LimitError

HOSTILE = Path(__file__).parent / "data" / "hostile"
GB = 1 << 30


def refused(path: Path, *words: str) -> str:
    """The load error of ``path``; it names the file and ``words`` and stays short."""
    with pytest.raises(DocumentLoadError) as caught:
        load_fmr(path) if path.suffix == ".fmr" else load_document(path)
    message = str(caught.value)
    assert path.name in message and all(word in message for word in words), message
    assert len(message) < 300, message
    return message


def finite_image(document: Document) -> np.ndarray:
    image = rasterise(build(document), 64, 64, samples=1)
    assert np.isfinite(image).all()
    return image


# --- unclean load errors and NaN pixels -------------------------------------------------------------------


def test_an_entry_name_flagged_utf8_that_is_not_is_a_load_error():
    refused(HOSTILE / "utf8-name.fmr", "utf-8")


def test_a_colour_of_1e308_is_refused():
    refused(HOSTILE / "huge-colour.fmr", "colours must be finite")


def test_a_point_colour_beyond_the_models_limit_is_a_load_error():
    refused(HOSTILE / "point-colour.fmr", "points[0]", "at most 1000")


def test_a_representation_with_shifted_segments_is_rebuilt_with_a_note():
    opened = load_fmr(HOSTILE / "shifted-segments.fmr")
    assert opened.representation is None
    assert any("rebuilt" in note for note in opened.notes), opened.notes
    finite_image(opened.document)


# --- coordinates ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["far-coordinates.xml", "scaled-coordinates.xml", "one-point-far.xml"])
def test_coordinates_far_off_the_canvas_are_refused(name):
    refused(HOSTILE / name, "off the canvas")


def test_coordinates_within_reach_are_clipped_not_sampled_out_there():
    """A curve reaching 4 canvas sides out is flattened as far as the canvas keeps it... and renders."""
    far = circle_points(256.0, 256.0, 60.0)
    far[4] = (256.0, 512.0 * 4.9)
    document = Document(512, 512, [DiffusionCurve(far, left=(ColorStop(0.0, (1, 0, 0)),),
                                                  right=(ColorStop(0.0, (0, 0, 1)),))])
    image = finite_image(document)
    assert image.min() >= -0.02 and image.max() <= 1.02  # the maximum principle


# --- canvases ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name, words", [("huge-canvas.xml", ("16384",)), ("thin-canvas.xml", ("16384",)),
                                         ("thin-largest-canvas.xml", ("64 times",))])
def test_canvases_too_large_or_too_thin_are_refused(name, words):
    refused(HOSTILE / name, *words)


def test_a_huge_canvas_gets_the_lattice_the_memory_allows():
    assert affordable_levels(11, 17, available=64 * GB) == 11
    assert affordable_levels(11, 17, available=3 * GB) == 9  # 2048 x 2048 cells would take 3.4 GB
    assert affordable_levels(11, 17, available=0) == 2
    assert affordable_levels(11, 65, available=3 * GB) == 8  # expansions of more terms: a coarser lattice


def test_builds_and_renders_that_would_not_fit_are_refused_before_they_start():
    check_build_memory(90_000, 8, 17, available=3 * GB)  # roses
    with pytest.raises(LimitError, match="needs about"):
        check_build_memory(400_000, 8, 17, available=3 * GB)
    with pytest.raises(LimitError, match="16,384 x 16,384 pixels"):
        check_image_memory(16384, 16384, available=16 * GB)


def test_rendering_the_largest_canvas_at_its_size_is_refused_before_any_build(tmp_path):
    out = tmp_path / "largest.png"
    code, _, err = run("render", str(HOSTILE / "largest-canvas.xml"), "-o", str(out))
    assert code == 2 and "16,384 x 16,384 pixels needs about" in err and not out.exists()


# --- degenerate and repeated geometry --------------------------------------------------------------------


def test_tiny_curves_solve_to_finite_colours():
    finite_image(load_document(HOSTILE / "tiny-curves.xml"))


def test_a_curve_repeated_300_times_renders_as_one_copy():
    document = load_document(HOSTILE / "duplicated.xml")
    curve = document.curves[0]
    once = len(curve.control_points) // 300 + 1
    single = Document(document.width, document.height,
                      [DiffusionCurve(curve.control_points[:once], left=curve.left, right=curve.right)])
    probes = np.random.default_rng(5).uniform(0, 512, (200, 2))
    np.testing.assert_allclose(evaluate_points(build(document), probes),
                               evaluate_points(build(single), probes), atol=1e-9)


def test_curves_leaving_a_point_along_one_tangent_keep_no_stretch_a_hair_apart():
    """tangent-fan.xml (issue 26): cubics leaving one point along one tangent ran 1e-5 px apart for a pixel or two;
    with different colours such pairs made systems no preconditioner could solve.  The later curve now keeps each
    stretch within ``COINCIDENT_DISTANCE`` of an earlier one."""
    document = load_document(HOSTILE / "tangent-fan.xml")
    segments = curve_segments(document)
    lines = shapely.linestrings(np.stack([segments.p, segments.q], axis=1))
    hair = COINCIDENT_DISTANCE / 10
    first, second = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=hair)
    apart = segments.origin[first, 0] != segments.origin[second, 0]
    first, second = first[apart], second[apart]
    beside = shapely.length(shapely.intersection(lines[second], shapely.buffer(lines[first], hair)))
    assert len(first) > 0 and beside.max() < 20 * hair  # they meet or cross; none runs beside another
    finite_image(document)


def test_curves_on_the_canvas_border_render_within_their_colours():
    image = finite_image(load_document(HOSTILE / "border-curves.xml"))
    assert image.min() >= -0.02 and image.max() <= 1.02


# --- sizes ------------------------------------------------------------------------------------------------


def orzan_file(path: Path, curves: list[np.ndarray], width: int = 400, height: int = 300) -> Path:
    parts = [f'<curve_set image_width="{width}" image_height="{height}">']
    for points in curves:
        xy = "".join(f'<control_point x="{y:.3f}" y="{x:.3f}"/>' for x, y in points)
        parts.append(f"<curve><control_points_set>{xy}</control_points_set><left_colors_set>"
                     '<left_color G="0" R="0" B="255" globalID="0"/></left_colors_set><right_colors_set>'
                     '<right_color G="0" R="255" B="0" globalID="0"/></right_colors_set></curve>')
    path.write_text("".join(parts) + "</curve_set>")
    return path


def test_a_curve_of_300001_control_points_is_refused_on_reading(tmp_path):
    points = np.random.default_rng(1).uniform((0, 0), (400, 300), (300_001, 2))
    refused(orzan_file(tmp_path / "many-points.xml", [points]), "30,001", "300,001")


def test_100000_curves_are_refused_on_reading(tmp_path):
    square = np.array([[10.0, 10.0], [11.0, 10.0], [11.0, 11.0], [10.0, 11.0]])
    refused(orzan_file(tmp_path / "many-curves.xml", [square] * 100_000), "50,000", "100,000")


def test_a_curve_with_more_stops_than_the_limit_is_refused_before_any_stop_is_read(tmp_path, monkeypatch):
    corners = "".join(f'<control_point x="{x}" y="{y}"/>' for x, y in ((10, 10), (10, 11), (11, 11), (10, 10)))
    stops = '<left_color G="0" R="0" B="255" globalID="0"/>' * (limits.MAX_CURVE_STOPS + 1)
    path = tmp_path / "many-stops.xml"
    path.write_text('<curve_set image_width="100" image_height="100"><curve><control_points_set>'
                    f'{corners}</control_points_set><left_colors_set>{stops}'
                    '</left_colors_set></curve></curve_set>')
    read = []
    monkeypatch.setattr(orzan, "_channel", lambda *args: read.append(args) or 0.0)
    refused(path, "curve 1", "10,001 left_color stops", "at most 10,000")
    assert read == []


def test_a_document_json_with_more_stops_than_the_limit_is_refused():
    document = Document(64, 64, [DiffusionCurve(circle_points(32.0, 32.0, 10.0), left=(ColorStop(0.0, (1, 0, 0)),))])
    data = json.loads(dumps_document(document))
    data["layers"][0]["curves"][0]["right"] = [{"position": 0.0, "color": [0, 0, 1]}] * (limits.MAX_CURVE_STOPS + 1)
    with pytest.raises(SchemaError, match=r"curves\[0\]\.right holds 10,001 stops; at most 10,000"):
        loads_document(json.dumps(data).encode())


def test_documents_made_in_code_are_held_to_the_stop_limits(monkeypatch):
    stops = tuple(ColorStop(i / 10, (0, 0, 1)) for i in range(41))
    curves = [DiffusionCurve(circle_points(32.0, 32.0, 10.0), right=stops) for _ in range(3)]
    monkeypatch.setattr(limits, "MAX_CURVE_STOPS", 40)
    with pytest.raises(LimitError, match="at most 40 stops on a side of a curve .layer 1. are read, got 41"):
        limits.check_document(Document(64, 64, curves))
    monkeypatch.setattr(limits, "MAX_CURVE_STOPS", 41)
    monkeypatch.setattr(limits, "MAX_STOPS", 100)
    with pytest.raises(LimitError, match="at most 100 stops are read, got 123"):
        build(Document(64, 64, curves))


def test_curves_that_would_flatten_into_millions_of_segments_are_refused_before_flattening(monkeypatch):
    points = np.random.default_rng(1).uniform((0, 0), (400, 300), (30_001, 2))
    document = Document(400, 300, [DiffusionCurve(points, left=(ColorStop(0.0, (1, 0, 0)),))])

    def never(*args):
        raise AssertionError("flattened")

    monkeypatch.setattr(curve_cache, "flatten_curves", never)
    with pytest.raises(LimitError, match="segments, more than the 2,000,000 allowed"):
        build(document)


def test_a_50_megabyte_number_stays_out_of_the_message(tmp_path):
    path = tmp_path / "long-number.xml"
    path.write_text('<curve_set image_width="100" image_height="100"><curve><control_points_set>'
                    f'<control_point x="{"1" * 50_000_000}" y="5"/>' + '<control_point x="5" y="5"/>' * 3 +
                    '</control_points_set></curve></curve_set>')
    message = refused(path)
    assert "111..." in message


# --- a solve that cannot converge -----------------------------------------------------------------------


@pytest.mark.slow
def test_curves_crowding_the_canvas_edge_are_refused_after_two_cycles_not_drawn_wrong(shared_data, monkeypatch):
    """poivron's curves with every control point on one of 8 points 1.28 px inside the corners and edge midpoints
    of a 128 px canvas (the fuzzing finding of issue 26, scaled down): the preconditioned GMRES diverged (relative
    residual 3e3 after its 300 iterations) and the build showed that wrong picture with a warning."""
    poivron = load_document(shared_data / "orzan_xml" / "berkbavas" / "poivron.xml")
    inset, side = 1.28, 128.0
    targets = inset + (side - 2 * inset) * np.array([(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0), (1, 0.5), (0.5, 1),
                                                    (0, 0.5)])
    rng = np.random.default_rng(0)
    curves = [DiffusionCurve(targets[rng.integers(0, 8, len(curve.control_points))], curve.left, curve.right)
              for curve in poivron.curves]
    iterations = []
    real_gmres = fast_solve.gmres

    def counted(*args, **kwargs):
        unknown, report = real_gmres(*args, **kwargs)
        iterations.append(report.iterations)
        return unknown, report

    monkeypatch.setattr(fast_solve, "gmres", counted)
    with pytest.raises(fast_solve.SingularSystemError, match="does not converge"):
        build(Document(128, 128, curves))
    assert iterations and iterations[-1] <= 2 * fast_solve.GMRES_RESTART
