"""Curves lying on top of each other: the later segment keeps the overlap."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import shapely
from shapes import straight_chain, uniform_curve

from fmr_editor.engine import build, evaluate_points, rasterise
from fmr_editor.engine.geometry.discretise import curve_segments
from fmr_editor.engine.geometry.overlaps import drop_covered_parts, drop_covered_parts_reference, overlapping_pairs
from fmr_editor.io import load_document
from fmr_editor.model import Document

PROBES = np.array([[20.0, 20.0], [50.0, 30.0], [80.0, 70.0], [40.0, 45.0], [60.0, 52.0]])


def test_a_curve_retracing_itself_renders_like_its_last_passes():
    # along y = 50: forwards 20 -> 80, back 80 -> 30, forwards 30 -> 45 (as curves in flower.xml do)
    retrace = uniform_curve(straight_chain([(20, 50), (80, 50), (30, 50), (45, 50)]), 0.9, 0.1)
    # later passes win: 20..30 keeps the first pass, 45..80 the backward one, 30..45 the last
    passes = [
        uniform_curve(straight_chain(ends), 0.9, 0.1)
        for ends in ([(20, 50), (30, 50)], [(80, 50), (45, 50)], [(30, 50), (45, 50)])
    ]
    got = evaluate_points(build(Document(100, 100, [retrace])), PROBES)
    expected = evaluate_points(build(Document(100, 100, passes)), PROBES)
    np.testing.assert_allclose(got, expected, atol=1e-6)


def test_the_later_of_two_coinciding_curves_wins():
    line = straight_chain([(10, 40), (90, 60)])
    first, second = uniform_curve(line, 1.0, 0.0), uniform_curve(line, 0.2, 0.6)
    got = evaluate_points(build(Document(100, 100, [first, second])), PROBES)
    expected = evaluate_points(build(Document(100, 100, [second])), PROBES)
    np.testing.assert_allclose(got, expected, atol=1e-9)


def test_dropping_covered_parts_keeps_the_union_and_leaves_no_overlap():
    rng = np.random.default_rng(3)
    doc = Document(100, 100, [
        uniform_curve(straight_chain([(a, 50.0), (b, 50.0)]), 1.0, 0.0) for a, b in rng.uniform(5, 95, (12, 2))
    ] + [uniform_curve(straight_chain([(50.0, 5.0), (50.0, 95.0)]), 0.5, 0.5)])
    seg = curve_segments(doc)
    assert len(overlapping_pairs(seg)[0]) == 0
    union = shapely.union_all(shapely.linestrings(np.stack([seg.p, seg.q], axis=1)))
    assert seg.lengths.sum() == pytest.approx(union.length, rel=1e-9)


def test_segments_without_overlaps_are_untouched():
    line = straight_chain([(10, 10), (90, 30)])
    seg = curve_segments(Document(100, 100, [uniform_curve(line, 1.0, 0.0)]))
    again = drop_covered_parts(seg)
    np.testing.assert_array_equal(again.p, seg.p)
    np.testing.assert_array_equal(again.q, seg.q)


def test_nearly_coinciding_curves_still_give_a_bounded_image():
    line = straight_chain([(10, 40), (90, 60)])
    shifted = line + [0.0, 1e-5]
    doc = Document(100, 100, [uniform_curve(line, 1.0, 0.0), uniform_curve(shifted, 0.2, 0.6)])
    image = rasterise(build(doc), 50, 50, samples=1)
    assert np.all(np.isfinite(image)) and image.min() >= -0.05 and image.max() <= 1.05


def test_flower_with_retraced_curves_solves_cleanly(shared_data):
    doc = load_document(shared_data / "orzan_xml" / "berkbavas" / "flower.xml")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rep = build(doc)
    image = rasterise(rep, 128, 128, samples=1)
    # the maximum principle: colours in [0, 1] stay in [0, 1], up to discretisation
    assert image.min() >= -0.05 and image.max() <= 1.05


def test_a_singular_system_falls_back_to_the_least_squares_solution(monkeypatch):
    from fmr_editor.engine.solve import dense as bem

    rng = np.random.default_rng(8)
    matrix = rng.normal(size=(6, 6))
    matrix[:, 5] = matrix[:, 4]  # two identical unknowns, as coinciding segments give
    rhs = matrix @ rng.normal(size=(6, 3))
    solve, least_squares = bem.dense_factors(matrix.copy(), matrix.copy)
    assert least_squares
    got = solve(rhs)
    np.testing.assert_allclose(matrix @ got, rhs, atol=1e-9)
    np.testing.assert_allclose(got[4], got[5], atol=1e-9)  # shared, not blown up


def test_the_bucket_filter_finds_every_pair_a_full_search_finds():
    """Collinear pieces in random directions (some just below pi: the wrap of the direction), tiny pieces,
    repeated pieces and noise: the same pairs as the plain search over every segment (``reference_pairs``)."""
    from fmr_editor.engine.geometry import overlaps
    from fmr_editor.engine.geometry.segments import Segments

    rng = np.random.default_rng(3)
    lines = []
    for angle in [*rng.uniform(0, np.pi, 30), np.pi - 1e-4, np.pi - 3e-7, 1e-7]:
        origin, t = rng.uniform(0, 1500, 2), np.array([np.cos(angle), np.sin(angle)])
        for _ in range(3):  # pieces of one line, overlapping some of the time
            a, b = np.sort(rng.uniform(-40, 40, 2))
            if rng.random() < 0.2:
                b = a + rng.uniform(1e-5, 1e-3)  # tiny: direction rounded off
            lines.append((origin + a * t, origin + b * t) if rng.random() < 0.5 else (origin + b * t, origin + a * t))
    for x, y in rng.uniform(0, 1000, (5, 2)):  # two horizontal pieces, one rising and one falling within the
        for rise in (2e-7, -2e-7):             # tolerance: their directions round to either end of [0, pi)
            lines.append((np.array([x, y]), np.array([x + 60, y + rise])))
    lines += [tuple(rng.uniform(0, 1500, (2, 2))) for _ in range(200)]
    lines += [lines[i][::-1] if i % 2 else lines[i] for i in rng.integers(0, len(lines), 30)]  # repeated
    p, q = np.array([line[0] for line in lines]), np.array([line[1] for line in lines])
    n = len(p)
    segments = Segments(p, q, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, bool), np.zeros((n, 3)))

    def covered(found):
        return drop_covered_parts(segments, pairs=found)

    fast, plain = covered(overlapping_pairs(segments)), covered(overlaps.reference_pairs(segments))
    assert len(fast) < n - 20
    np.testing.assert_array_equal(fast.p, plain.p)
    np.testing.assert_array_equal(fast.q, plain.q)
    # a repeated segment pairs with its last twin only; every other pair as the full search finds it
    twins = overlaps.last_twins(segments)
    plain_pairs = [(a, b, start, end) for a, b, start, end in
                   zip(*(np.round(v, 9).tolist() for v in overlaps.reference_pairs(segments)))
                   if twins[a] == b or (twins[a] == a and twins[b] == b)]
    assert sorted(zip(*(np.round(v, 9).tolist() for v in overlapping_pairs(segments)))) == sorted(plain_pairs)


def assert_same_segments(got, expected) -> None:
    for name in ("p", "q", "jump", "mean", "on_border", "flux", "origin"):
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
        assert getattr(got, name).tobytes() == getattr(expected, name).tobytes(), name  # -0.0 too


def test_dropping_covered_parts_equals_the_plain_sweep():
    """Stretches nested, chained, starting together, ending together, covering a segment whole: the vectorised
    sweep gives the plain loop's pieces (``drop_covered_parts_reference``) bit for bit."""
    from fmr_editor.engine.geometry.segments import Segments

    rng = np.random.default_rng(11)
    ends = np.sort(rng.choice(np.linspace(0, 90, 31), (120, 2)), axis=1)  # shared end points: ties
    ends = ends[ends[:, 1] > ends[:, 0]]
    y = rng.choice([10.0, 40.0, 70.0], len(ends))
    p, q = np.column_stack([ends[:, 0] + 5, y]), np.column_stack([ends[:, 1] + 5, y])
    flip = rng.random(len(p)) < 0.5
    p[flip], q[flip] = q[flip].copy(), p[flip].copy()
    n = len(p)
    segments = Segments(p, q, rng.random((n, 3)), rng.random((n, 3)), np.zeros(n, bool), np.zeros((n, 3)))
    pairs = overlapping_pairs(segments)
    assert len(pairs[0]) > 200
    assert_same_segments(drop_covered_parts(segments, pairs=pairs), drop_covered_parts_reference(segments, pairs=pairs))


@pytest.mark.parametrize("name", ["flower", "fruits"])
def test_dropping_covered_parts_of_real_files_equals_the_plain_sweep(shared_data, name):
    from fmr_editor.engine.geometry.discretise import clip_to_canvas, from_curve
    from fmr_editor.engine.geometry.flatten import flatten_curves
    from fmr_editor.engine.geometry.segments import concatenate

    doc = load_document(shared_data / "orzan_xml" / "berkbavas" / f"{name}.xml")
    flat = flatten_curves(doc.curves, 0.05, 2.0)
    segments = clip_to_canvas(concatenate([from_curve(part, curve.id) for part, curve in zip(flat, doc.curves)]),
                              doc.width, doc.height)
    pairs = overlapping_pairs(segments)
    assert_same_segments(drop_covered_parts(segments, pairs=pairs), drop_covered_parts_reference(segments, pairs=pairs))


def test_covered_stretches_equal_a_sampled_reference():
    """Nearly parallel pairs, crossing, touching, a hair apart or further: the stretch ``shared_stretches`` gives is
    the set of the earlier's sample points within the distance of the later's line, between the later's ends'
    projections."""
    from fmr_editor.engine.geometry.overlaps import COINCIDENT_DISTANCE, MAX_SINE, shared_stretches
    from fmr_editor.engine.geometry.segments import Segments

    rng = np.random.default_rng(21)
    count = 400
    angle = rng.uniform(0, np.pi, count)
    turn = rng.choice([0.0, 1e-4, 0.01, 0.05, 0.2], count) * rng.choice([-1, 1], count) + rng.choice([0, np.pi], count)
    along = np.column_stack([np.cos(angle), np.sin(angle)])
    p = rng.uniform(0, 100, (count, 2))
    q = p + rng.uniform(0.5, 3, count)[:, None] * along
    shift = rng.choice([0.0, 0.003, 0.02], count)[:, None] * along[:, ::-1] * [1, -1]
    later_p = p + rng.uniform(-1, 2, count)[:, None] * along + shift
    later_along = np.column_stack([np.cos(angle + turn), np.sin(angle + turn)])
    later_q = later_p + rng.uniform(0.5, 3, count)[:, None] * later_along
    n = 2 * count
    segments = Segments(np.concatenate([p, later_p]), np.concatenate([q, later_q]), np.zeros((n, 3)),
                        np.zeros((n, 3)), np.zeros(n, bool), np.zeros((n, 3)))
    earlier, _, start, end = shared_stretches(segments, np.arange(count), np.arange(count, n),
                                              COINCIDENT_DISTANCE)
    got = dict(zip(earlier.tolist(), zip(start.tolist(), end.tolist())))
    assert 50 < len(got) < count - 50
    s = np.linspace(0, 1, 20_001)
    for i in range(count):
        points = p[i] + s[:, None] * (q[i] - p[i])
        direction = later_q[i] - later_p[i]
        unit = direction / np.hypot(*direction)
        rel = points - later_p[i]
        off = np.abs(rel[:, 0] * unit[1] - rel[:, 1] * unit[0])
        length = np.hypot(*(q[i] - p[i]))
        d = (q[i] - p[i]) / length
        ends = np.array([(later_p[i] - p[i]) @ d, (later_q[i] - p[i]) @ d]) / length
        beside = (s >= ends.min()) & (s <= ends.max())
        inside = s[(off <= COINCIDENT_DISTANCE) & beside]
        parallel = abs(d[0] * unit[1] - d[1] * unit[0]) <= MAX_SINE
        expected = parallel and len(inside) and (inside[-1] - inside[0]) * length > COINCIDENT_DISTANCE + 1e-3
        if expected:
            np.testing.assert_allclose(got[i], (inside[0], inside[-1]), atol=1e-4)
        elif i in got:  # only at the edge of the rule: a stretch just the distance long
            assert (got[i][1] - got[i][0]) * length < COINCIDENT_DISTANCE + 1e-3
