"""The one-pass raster kernel (``kernels.subcells``) against plain references and the exact near split."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from shapes import circle_points, straight_chain

from fmr_editor.engine import Settings, build, raster, rasterise
from fmr_editor.engine.fmm.orders import sample_degrees
from fmr_editor.engine.kernels.fastmath import INV_TWO_PI
from fmr_editor.engine.kernels.grid import far_field_grid, near_field_grid
from fmr_editor.engine.kernels.local_grid import largest_offsets, local_field_grid, local_field_reference
from fmr_editor.engine.kernels.potentials import direct_sum_reference
from fmr_editor.engine.kernels.segment_sums import direct_sum
from fmr_editor.engine.kernels.subcells import _p2l_state, _p2l_sums, p2l_reference, subcell_field_grid
from fmr_editor.engine.raster import far_field_reference, sample_coordinates
from fmr_editor.model import ColorStop, DiffusionCurve, Document

#: What the expansions of segments at least 2 sub-cells away may change (a 400th of an 8-bit level).
EXPANSION_TOLERANCE = 1e-5


@pytest.fixture(scope="module")
def rep():
    """A built 96 x 96 document: a circle and a chain, with colour gradients (levels 3: 12 px cells)."""
    rng = np.random.default_rng(31)
    stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 1.0, 2.0))
    curves = (DiffusionCurve(circle_points(45, 50, 30), left=stops, right=stops[::-1]),
              DiffusionCurve(straight_chain([(8, 20), (50, 12), (90, 30)]), left=stops, right=stops))
    return build(Document(96, 96, curves), Settings(levels=3))


def exact(rep, xs, ys):
    """Far field from the local expansions (numpy) plus the exact near sum of the 3x3 blocks."""
    seg, lattice = rep.segments, rep.lattice
    values = local_field_reference(rep.local, rep.order, xs, ys, lattice.cell_size)
    return near_field_grid(xs, ys, lattice.cells_per_side, lattice.cell_size, rep.cell_start,
                           seg.p, seg.q, seg.flux, seg.jump, out=np.ascontiguousarray(values))


def kernel(rep, xs, ys, **options):
    seg = rep.segments
    return subcell_field_grid(rep.local, rep.order, xs, ys, rep.lattice.cell_size, rep.cell_start,
                              seg.p, seg.q, seg.flux, seg.jump, **options)


def test_local_field_reference_equals_the_cell_polynomials(rep):
    xs, ys = sample_coordinates(50, 96, 1), sample_coordinates(41, 96, 2)
    np.testing.assert_allclose(local_field_reference(rep.local, rep.order, xs, ys, rep.lattice.cell_size),
                               far_field_reference(rep.polynomials(), xs, ys, rep.lattice.cell_size),
                               rtol=0, atol=1e-11)


def random_expansions(rng, n, terms):
    """Scaled local expansions ``(n, n, 3, terms)`` whose terms fall like a converging series."""
    scale = 0.5 ** np.arange(terms)
    return (rng.normal(size=(n, n, 3, terms)) + 1j * rng.normal(size=(n, n, 3, terms))) * scale


@pytest.mark.parametrize("xs, ys", [(sample_coordinates(64, 64, 1), sample_coordinates(64, 64, 1)),
                                    (sample_coordinates(8, 64, 1), sample_coordinates(21, 64, 3)[5:40]),
                                    (np.sort(np.r_[np.random.default_rng(2).uniform(-3, 67, 41), 16.0, 16.0]),
                                     np.arange(0.0, 64.5, 4.0))])
def test_compiled_local_field_equals_the_reference(xs, ys):
    rng = np.random.default_rng(37)
    local = random_expansions(rng, 8, 11)
    for order in (0, 4, 8):
        expected = local_field_reference(local, order, xs, ys, 8.0)
        got = local_field_grid(local, order, xs, ys, 8.0)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("in_step", [True, False])
def test_a_row_of_cells_whose_samples_lie_alike_makes_the_powers_of_w_once(in_step):
    """In a raster in step with the lattice (8 samples a cell side, as lady_bug at 512^2) every cell's samples lie
    where its neighbour's do, and a row of cells makes one table of the powers of ``w``; samples moved in every
    other cell make one a cell.  The values are the reference's either way."""
    local = random_expansions(np.random.default_rng(40), 8, 11)
    xs = sample_coordinates(64, 64, 1)
    if not in_step:
        xs = xs + 0.3 * (xs // 8 % 2)  # still in their cells
    made, degrees = np.zeros(8, np.int64), sample_degrees(8)
    got = local_field_grid(local, 8, xs, xs, 8.0, degrees=degrees, tables_made=made)
    expected = local_field_reference(local, 8, xs, xs, 8.0, degrees)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    assert made.tolist() == [1 if in_step else 8] * 8


def test_each_cell_takes_the_degree_its_samples_places_need():
    """Cells whose samples lie nearer their centre take fewer terms (``orders.sample_degrees``): at the centre
    the constant term alone (the higher terms, poisoned here, are never read), a band of a grid the whole
    grid's degrees; and compiled and plain forms agree on every cell."""
    rng = np.random.default_rng(39)
    local = random_expansions(rng, 8, 9)
    degrees = sample_degrees(8)
    assert degrees[0] < degrees[len(degrees) // 2] < degrees[-1] == 8 and np.all(np.diff(degrees) >= 0)
    centres = np.arange(8) * 8.0 + 4.0
    poisoned = local.copy()
    poisoned[..., 1:] = np.nan
    at_centres = local_field_grid(poisoned, 8, centres, centres, 8.0, degrees=degrees)
    np.testing.assert_allclose(at_centres, local[..., 0].real / (2 * np.pi), rtol=1e-15)
    for samples in (2, 4, 8):  # a pixel each, at radii of 0.35 (fewer terms), 0.53 and 0.62 cells (all)
        xs = sample_coordinates(8 * samples, 64, 1)
        expected = local_field_reference(local, 8, xs, xs, 8.0, degrees)
        np.testing.assert_allclose(local_field_grid(local, 8, xs, xs, 8.0, degrees=degrees), expected,
                                   rtol=0, atol=1e-12 * np.abs(expected).max())
        full = local_field_reference(local, 8, xs, xs, 8.0)
        assert (samples == 2) != np.array_equal(expected, full)
        band = slice(samples // 2, samples * 3)  # rows cutting cells, their degrees the whole grid's
        offsets = (largest_offsets(xs, 8.0, 8), largest_offsets(xs, 8.0, 8))
        np.testing.assert_allclose(local_field_grid(local, 8, xs, xs[band], 8.0, degrees=degrees, offsets=offsets),
                                   local_field_grid(local, 8, xs, xs, 8.0, degrees=degrees)[band], rtol=0, atol=1e-14)


def test_cells_of_degree_0_read_their_centre_values():
    """Given ``centres`` (``Representation.centre_values``), cells whose samples all lie on their centre read
    them, not their expansion (poisoned here), and give the values the expansion gives; other cells are not
    touched by them."""
    rng = np.random.default_rng(41)
    local = random_expansions(rng, 8, 9)
    centres = np.ascontiguousarray(local[..., 0].real) * INV_TWO_PI
    on_centres = np.arange(8) * 8.0 + 4.0
    expected = local_field_grid(local, 8, on_centres, on_centres, 8.0, degrees=sample_degrees(8))
    poisoned = local.copy()
    poisoned[...] = np.nan
    got = local_field_grid(poisoned, 8, on_centres, on_centres, 8.0, degrees=sample_degrees(8), centres=centres)
    assert np.array_equal(got, expected)
    off = sample_coordinates(16, 64, 1)  # two samples a cell side, off the centres: the expansions, all of them
    np.testing.assert_array_equal(local_field_grid(local, 8, off, off, 8.0, centres=np.full_like(centres, np.nan)),
                                  local_field_grid(local, 8, off, off, 8.0))
    with pytest.raises(ValueError, match="centres"):
        local_field_grid(local, 8, off, off, 8.0, centres=centres[:4])


def test_a_raster_on_the_cell_centres_reads_the_values_the_build_wrote(rep):
    """One sample a cell, on its centre (the paper's level-10 case): the raster with the build's ``centres``
    equals the raster of the same representation taking them from its expansions."""
    assert rep.centres is not None
    plain = replace(rep, centres=None)
    assert np.array_equal(plain.centre_values, rep.centres)
    cells = rep.lattice.cells_per_side
    np.testing.assert_array_equal(rasterise(rep, cells, cells, samples=1), rasterise(plain, cells, cells, samples=1))


def test_fewer_terms_keep_the_raster_as_near_the_direct_sum(rep):
    """The degrees chosen by the samples' places change the raster's error against the direct boundary sum by
    no more than the pixels' own truncation makes it (and stay far under a level)."""
    xs, ys = sample_coordinates(96, 96, 1), sample_coordinates(48, 96, 2)
    seg = rep.segments
    points = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1).reshape(-1, 2)
    exact = direct_sum(points, seg.p, seg.q, seg.flux, seg.jump).reshape(len(ys), len(xs), 3)
    errors = [np.abs(kernel(rep, xs, ys, degrees=chosen) - exact).max() for chosen in (None, sample_degrees(rep.order))]
    assert errors[1] <= 2 * errors[0] and errors[1] < 0.1 / 255


def test_compiled_local_field_overwrites_out_but_in_skipped_cells():
    rng = np.random.default_rng(38)
    local = random_expansions(rng, 4, 9)
    xs, ys = sample_coordinates(20, 32, 1), sample_coordinates(12, 32, 1)
    skip = rng.random((4, 4)) < 0.5
    out = np.full((12, 20, 3), 7.0)
    assert local_field_grid(local, 8, xs, ys, 8.0, out=out, skip=skip) is out
    skipped = skip[np.minimum(ys // 8, 3).astype(int)[:, None], np.minimum(xs // 8, 3).astype(int)[None, :]]
    assert skipped.any() and not skipped.all()
    np.testing.assert_array_equal(out[skipped], 7.0)
    np.testing.assert_allclose(out[~skipped], local_field_reference(local, 8, xs, ys, 8.0)[~skipped], rtol=1e-12)
    with pytest.raises(ValueError, match="order"):
        local_field_grid(local, 9, xs, ys, 8.0)
    with pytest.raises(ValueError, match="skip"):
        local_field_grid(local, 8, xs, ys, 8.0, skip=skip[:3])


@pytest.mark.parametrize("xs, ys", [(sample_coordinates(96, 96, 1), sample_coordinates(96, 96, 1)),
                                    (sample_coordinates(40, 96, 3), sample_coordinates(23, 96, 3)[10:50]),
                                    (np.sort(np.r_[np.random.default_rng(1).uniform(-2, 98, 37), 24.0, 24.0]),
                                     np.arange(0.0, 96.5, 6.0))])
def test_without_expansions_the_kernel_is_the_polynomial_plus_the_exact_near_sum(rep, xs, ys):
    expected = exact(rep, xs, ys)
    assert np.ptp(expected) > 0.3
    for split in (1, 2, 3):
        np.testing.assert_allclose(kernel(rep, xs, ys, split=split, separation=np.inf), expected, rtol=0, atol=1e-9)


def test_cells_without_block_segments_take_the_local_field_alone():
    rng = np.random.default_rng(39)
    stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 1.0))
    document = Document(96, 96, (DiffusionCurve(circle_points(40, 52, 9), left=stops, right=stops[::-1]),))
    small = build(document, Settings(levels=4))  # 6 px cells: most of the canvas is far from any segment
    n = small.lattice.cells_per_side
    counts = np.pad(np.diff(small.cell_start).reshape(n, n), 1)
    block = sum(counts[1 + dy : 1 + dy + n, 1 + dx : 1 + dx + n] for dy in (-1, 0, 1) for dx in (-1, 0, 1))
    assert (block == 0).sum() > 50 and (block > 0).sum() > 50
    xs = ys = sample_coordinates(96, 96, 4)
    expected = exact(small, xs, ys)
    for split in (1, 2, 4):
        np.testing.assert_allclose(kernel(small, xs, ys, split=split, separation=np.inf), expected, rtol=0, atol=1e-9)
        np.testing.assert_allclose(kernel(small, xs, ys, split=split), expected, rtol=0, atol=EXPANSION_TOLERANCE)


@pytest.mark.parametrize("split", [2, 4])
def test_expanded_segments_stay_within_the_tolerance_of_the_exact_split(rep, split):
    xs = ys = sample_coordinates(96, 96, 3)
    expected = exact(rep, xs, ys)
    got = kernel(rep, xs, ys, split=split)
    assert np.abs(got - expected).max() > 1e-14  # segments were expanded
    np.testing.assert_allclose(got, expected, rtol=0, atol=EXPANSION_TOLERANCE)


def test_the_kernel_overwrites_out_and_checks_its_input(rep):
    xs, ys = sample_coordinates(30, 96, 1), sample_coordinates(20, 96, 1)
    out = np.full((20, 30, 3), 7.0)
    assert kernel(rep, xs, ys, split=2, out=out) is out
    np.testing.assert_array_equal(out, kernel(rep, xs, ys, split=2))
    with pytest.raises(ValueError, match="order"):
        subcell_field_grid(rep.local, rep.local.shape[-1], xs, ys, 12.0, rep.cell_start, *([np.zeros((0, 2))] * 4))
    with pytest.raises(ValueError, match="split"):
        kernel(rep, xs, ys, split=0)
    with pytest.raises(ValueError, match="sorted"):
        kernel(rep, xs[::-1], ys)


def random_segments(rng, count, radius):
    """Segments with both ends beyond ``radius`` of the origin, random E and C."""
    p = rng.uniform(-3 * radius, 3 * radius, (4 * count, 2))
    q = p + rng.normal(0, radius / 3, p.shape)
    keep = (np.hypot(*p.T) > radius) & (np.hypot(*q.T) > radius)
    p, q = p[keep][:count], q[keep][:count]
    # the whole segment beyond radius: its closest point to the origin
    d = q - p
    along = np.clip(-(p * d).sum(1) / (d * d).sum(1), 0, 1)
    keep = np.hypot(*(p + along[:, None] * d).T) > radius
    p, q = p[keep], q[keep]
    return p, q, rng.normal(size=(len(p), 3)), rng.normal(size=(len(p), 3))


def test_p2l_reference_converges_to_the_direct_sum():
    rng = np.random.default_rng(32)
    size = 8.0
    p, q, flux, jump = random_segments(rng, 40, 2 * size)
    targets = rng.uniform(-size / 2, size / 2, (60, 2))
    w = (targets[:, 0] + 1j * targets[:, 1]) / size
    expected = direct_sum_reference(targets, p, q, flux, jump)
    errors = []
    for order in (4, 8, 16):
        coeffs = p2l_reference(p, q, flux, jump, 0j, size, order)
        errors.append(np.abs((coeffs[None] * w[:, None, None] ** np.arange(order + 1)).sum(-1).real / (2 * np.pi)
                             - expected).max())
    ratio = 1 / (2 * np.sqrt(2))  # a corner of the cell against a segment 2 cells away
    scale = np.abs(expected).max()
    assert errors[0] > errors[1] > errors[2]
    for order, error in zip((4, 8, 16), errors):
        assert error < 40 * scale * ratio ** (order + 1)


def test_compiled_expansions_equal_the_reference():
    rng = np.random.default_rng(33)
    p, q, flux, jump = random_segments(rng, 50, 5.0)
    centre, size, order = (3.0, -2.0), 4.0, 9
    d = q - p
    h = np.hypot(*d.T)
    table = np.concatenate([p.T, q.T, (d / h[:, None]).T, h[None], flux.T, jump.T])
    coeffs = np.zeros((3, order + 1), complex)
    _p2l_state(len(p), table, *centre, size, state := np.empty((12, len(p))))
    _p2l_sums(len(p), table, state, size, order, coeffs)
    expected = p2l_reference(p + 0.0, q + 0.0, flux, jump, complex(*centre), size, order)
    expected[:, 0] = expected[:, 0].real
    np.testing.assert_allclose(coeffs, expected, rtol=1e-11, atol=1e-11 * np.abs(expected).max())


def test_rasterise_splits_cells_of_many_samples_within_the_tolerance(rep, monkeypatch):
    assert raster.split_for(36.0) == (4, raster.SEPARATION)
    assert raster.split_for(15.0) == (1, np.inf)
    image = rasterise(rep, 288, 288, samples=1)  # 36 samples a cell side: 4 x 4 sub-cells
    monkeypatch.setattr(raster, "SUB_CELL_SAMPLES", 10**9)
    whole = rasterise(rep, 288, 288, samples=1)
    assert np.abs(image - whole).max() > 1e-14
    np.testing.assert_allclose(image, whole, rtol=0, atol=EXPANSION_TOLERANCE)
    rng = np.random.default_rng(34)
    pixels = rng.integers(0, 288, (200, 2))
    seg = rep.segments
    direct = direct_sum((pixels + 0.5) / 3, seg.p, seg.q, seg.flux, seg.jump)
    assert np.abs(image[pixels[:, 1], pixels[:, 0]] - direct).max() < 1 / 255


def test_far_field_grid_adds_and_truncates():
    rng = np.random.default_rng(36)
    poly = rng.normal(size=(8, 8, 3, 7, 7))
    xs, ys = sample_coordinates(37, 64, 1), sample_coordinates(23, 64, 2)
    truncated = poly.copy()
    truncated[..., 4:, :] = 0
    truncated[..., :, 4:] = 0
    base = rng.normal(size=(len(ys), len(xs), 3))
    out = base.copy()
    assert far_field_grid(poly, xs, ys, 8.0, order=3, out=out) is out
    np.testing.assert_allclose(out - base, far_field_reference(truncated, xs, ys, 8.0), rtol=0, atol=1e-12)
