"""The canvas's data for the shader (packing), its change bounds and the view, without OpenGL."""

from __future__ import annotations

import numpy as np
import pytest
from layered import translucent_layers
from shapes import scattered_document

from fmr_editor.engine import LiveRepresentation, LiveStack, build
from fmr_editor.engine.kernels.segment_sums import near_sum
from fmr_editor.model import DiffusionPoint, edits
from fmr_editor.render import bounds, packing
from fmr_editor.render.view import View


@pytest.fixture(scope="module")
def curves():
    return build(scattered_document(128, circles=4, seed=3))


@pytest.fixture(scope="module")
def with_points():
    doc = scattered_document(128, circles=2, seed=5)
    points = [DiffusionPoint((30.0 + 9 * i, 50.0 + 5 * i), radius, (0.2, 0.5, 0.9), 0.7)
              for i, radius in enumerate((0.8, 1.5, 3.0, 12.0, 40.0))]
    return build(doc.with_points(points))


def unpack_harmonic(rep, texels):
    """``K_l`` (cells, channel, l) complex from packed harmonic texels."""
    n, order = rep.lattice.cells_per_side, rep.order
    values = texels.reshape(n * n, order + 1, 2, 4)[..., :3]
    return (values[:, :, 0] + 1j * values[:, :, 1]).transpose(0, 2, 1)


def unpack_tensor(rep, texels):
    n, order = rep.lattice.cells_per_side, rep.order
    values = texels.reshape(n * n, order + 1, order + 1, 4)[..., :3]
    return values.transpose(0, 3, 1, 2).reshape(n, n, 3, order + 1, order + 1)


def test_harmonic_form_evaluates_like_the_polynomials(curves):
    assert packing.uses_harmonic(curves)
    texels = packing.cell_coefficients(curves)
    assert texels.dtype == np.float32 and texels.shape[1] == 4
    k = unpack_harmonic(curves, texels)
    rng = np.random.default_rng(0)
    xi, eta = rng.uniform(-0.5, 0.5, (2, 20))
    z = (xi + 1j * eta)[None, :] ** np.arange(curves.order + 1)[:, None]  # (l, samples)
    harmonic = np.einsum("kcl,lm->kcm", k, z).real
    poly = curves.polynomials().reshape(len(k), 3, curves.order + 1, curves.order + 1)
    tensor = np.einsum("kcij,im,jm->kcm", poly, xi[None] ** np.arange(curves.order + 1)[:, None],
                       eta[None] ** np.arange(curves.order + 1)[:, None])
    scale = np.abs(tensor).max()
    assert np.abs(harmonic - tensor).max() <= 1e-6 * scale


def test_tensor_form_is_the_polynomials(with_points):
    assert not packing.uses_harmonic(with_points)
    texels = packing.cell_coefficients(with_points)
    np.testing.assert_allclose(unpack_tensor(with_points, texels), with_points.polynomials(), rtol=1e-6, atol=1e-6)
    with pytest.raises(ValueError):
        packing.cell_coefficients(with_points, harmonic=True)


WEIGHTS = np.array([0.2126, 0.7152, 0.0722])  # a mask's luminance


def unpack_scalar(rep, texels):
    """A scalar field's ``K_l`` (cells, l) complex, or ``c[i, j]`` (n, n, i, j), from its packed texels."""
    n, order = rep.lattice.cells_per_side, rep.order
    rows = texels.reshape(n * n, -1).astype(np.float64)
    if packing.uses_harmonic(rep):
        pairs = rows[:, : 2 * (order + 1)].reshape(n * n, order + 1, 2)
        return pairs[..., 0] + 1j * pairs[..., 1]
    return rows.reshape(n * n, order + 1, -1)[:, :, : order + 1].reshape(n, n, order + 1, order + 1)


def test_a_scalar_field_packs_the_weighted_sum_of_the_channels(curves, with_points):
    """Four values a texel: the coefficients' weighted sum, each segment's E and C, each near point's weight."""
    for rep in (curves, with_points):
        texels = packing.cell_coefficients(rep, weights=WEIGHTS)
        n, harmonic = rep.lattice.cells_per_side, packing.uses_harmonic(rep)
        assert texels.shape == (n * n * packing.texels(rep.order, harmonic, scalar=True), 4)
        assert packing.texels(rep.order, harmonic, scalar=True) * 3 <= packing.texels(rep.order, harmonic) + 3
        full = packing.cell_coefficients(rep)
        if harmonic:
            expected = np.einsum("c,kcl->kl", WEIGHTS, unpack_harmonic(rep, full))
        else:
            expected = np.einsum("c,ijcpq->ijpq", WEIGHTS, unpack_tensor(rep, full))
        np.testing.assert_allclose(unpack_scalar(rep, texels), expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
    table, full = packing.segment_table(curves, weights=WEIGHTS), packing.segment_table(curves)
    rows, full_rows = table.texels.reshape(-1, 2, 4), full.texels.reshape(-1, 3, 4)
    np.testing.assert_array_equal(rows[:, 0], full_rows[:, 0])  # the same entries, the same end points
    np.testing.assert_allclose(rows[:, 1, 0], full_rows[:, 1, :3] @ WEIGHTS, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(rows[:, 1, 1], full_rows[:, 2, :3] @ WEIGHTS, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(rows[:, 1, 2], full_rows[:, 1, 3])  # the length
    points, full_points = packing.point_table(with_points, WEIGHTS), packing.point_table(with_points)
    np.testing.assert_array_equal(points.texels[:, :3], full_points.texels.reshape(-1, 2, 4)[:, 0, :3])
    np.testing.assert_allclose(points.texels[:, 3], full_points.texels.reshape(-1, 2, 4)[:, 1, :3] @ WEIGHTS,
                               rtol=1e-6)
    flux, jump = np.random.default_rng(5).normal(size=(2, *curves.segments.flux.shape))
    packing.refill(table, flux, jump)
    np.testing.assert_array_equal(table.texels, packing.segment_table(curves, flux, jump, weights=WEIGHTS).texels)


@pytest.mark.parametrize("index", [1, 2], ids=["tensor", "harmonic"])
def test_an_alpha_field_packs_as_the_fourth_channel_of_its_image(index):
    """A translucent layer's alpha field rides in its image's tables: its first channel where the texels' fourth
    component was 0, every other value as the image alone packs it."""
    layer = LiveStack(translucent_layers()).composite.layers[index]
    image, alpha = layer.image, layer.alpha
    harmonic = packing.uses_harmonic(image)
    assert harmonic == (index == 2)  # the middle layer's image has points: the tensor form, its alpha's too
    both = packing.cell_coefficients(image, alpha=alpha).reshape(-1, 4)
    np.testing.assert_array_equal(both[:, :3], packing.cell_coefficients(image)[:, :3])
    np.testing.assert_array_equal(both[:, 3], packing.cell_coefficients(alpha, harmonic=harmonic)[:, 0])
    table, plain = packing.segment_table(image, alpha=alpha), packing.segment_table(image)
    rows, plain_rows = table.texels.reshape(-1, 3, 4), plain.texels.reshape(-1, 3, 4)
    np.testing.assert_array_equal(rows[:, 0], plain_rows[:, 0])
    np.testing.assert_array_equal(rows[:, 1:, :3], plain_rows[:, 1:, :3])
    entries = table.segments
    np.testing.assert_array_equal(rows[:, 1, 3], alpha.near[0].flux[entries, 0].astype(np.float32))
    np.testing.assert_array_equal(rows[:, 2, 3], alpha.near[0].jump[entries, 0].astype(np.float32))
    flux, jump = np.random.default_rng(6).normal(size=(2, len(image.near[0].p), 4))
    packing.refill(table, flux, jump)
    np.testing.assert_array_equal(table.texels, packing.segment_table(image, flux, jump, alpha=alpha).texels)


def test_some_cells_pack_like_all_of_them(with_points, curves):
    for rep in (with_points, curves):
        per_cell = packing.cell_coefficients(rep).reshape(rep.lattice.cells_per_side**2, -1)
        cells = np.array([0, 3, 4, 17, per_cell.shape[0] - 1])
        np.testing.assert_array_equal(packing.cell_coefficients(rep, cells).reshape(len(cells), -1), per_cell[cells])


def test_each_cell_lists_its_blocks_segments_relative_to_its_centre(curves, monkeypatch):
    table = packing.segment_table(curves)
    seg, lattice = curves.segments, curves.lattice
    n, size = lattice.cells_per_side, lattice.cell_size
    rows = table.texels.reshape(-1, 3, 4).astype(np.float64)
    assert table.cell_start[-1] == len(rows) == len(table.segments)
    own = lattice.cell_of(seg.midpoints)  # (row, column) of each segment's own cell
    for cell in (0, n - 1, n + 1, n * n // 2 + 3, n * n - 1):
        r, c = divmod(cell, n)
        listed = table.segments[table.cell_start[cell] : table.cell_start[cell + 1]]
        near = np.flatnonzero((np.abs(own[:, 0] - r) <= 1) & (np.abs(own[:, 1] - c) <= 1))
        np.testing.assert_array_equal(np.sort(listed), near)
        entries = rows[table.cell_start[cell] : table.cell_start[cell + 1]]
        centre = (np.array([c, r]) + 0.5) * size
        np.testing.assert_allclose(entries[:, 0, :2] + centre, seg.p[listed], atol=1e-4)
        np.testing.assert_allclose(entries[:, 0, 2:] + centre, seg.q[listed], atol=1e-4)
        assert np.abs(entries[:, 0]).max(initial=0) <= 2 * size  # small coordinates: no cancellation
        np.testing.assert_allclose(entries[:, 1, :3], seg.flux[listed], rtol=1e-6)
        np.testing.assert_allclose(entries[:, 2, :3], seg.jump[listed], rtol=1e-6)
    flux, jump = np.random.default_rng(4).normal(size=(2, *seg.flux.shape))
    monkeypatch.setattr(packing, "REFILL_CHUNK", 1000)  # a few chunks
    assert len(table.segments) > 3000
    packing.refill(table, flux, jump)
    np.testing.assert_array_equal(table.texels, packing.segment_table(curves, flux=flux, jump=jump).texels)
    kept = np.zeros(len(seg.p), bool)
    kept[::7] = True
    some = packing.segment_table(curves, keep=kept)
    assert set(some.segments) == set(np.flatnonzero(kept))
    assert len(some.segments) < len(table.segments) / 5


def test_near_points_table(with_points, curves):
    table = packing.point_table(with_points)
    near = with_points.points.near
    assert len(near) >= 1  # the 0.8 px point at least
    rows = table.texels.reshape(-1, 2, 4)
    np.testing.assert_allclose(rows[:, 0, :2], near.points.positions, rtol=1e-6)
    np.testing.assert_allclose(rows[:, 0, 2], 1 / near.points.radii**2, rtol=1e-6)
    np.testing.assert_array_equal(table.members, near.members)
    empty = packing.point_table(curves)
    assert len(empty.members) == 0 and len(empty.start) == curves.lattice.cells_per_side**2 + 1


def test_cell_runs():
    assert packing.cell_runs(np.array([], int)) == []
    assert packing.cell_runs(np.array([2, 3, 4, 9, 11, 12])) == [(2, 5), (9, 10), (11, 13)]
    assert packing.cell_runs(np.arange(0, 200, 2), max_runs=10) == [(0, 199)]


@pytest.mark.parametrize("channels", [3, 4], ids=["colour", "with alpha"])
def test_far_bound_bounds_the_change_of_the_far_field(curves, with_points, channels):
    rng = np.random.default_rng(1)
    for rep in (curves, with_points):
        harmonic = packing.uses_harmonic(rep)
        per_cell = packing.cell_coefficients(rep).reshape(rep.lattice.cells_per_side**2, -1).astype(np.float64)
        delta = rng.normal(size=per_cell.shape) * 1e-3
        delta.reshape(len(delta), -1, 4)[..., channels:] = 0.0  # the texels' unused fourth component
        delta.reshape(len(delta), -1, 4)[..., 3] *= 10  # an alpha that changes most: the bound must see it
        bound = bounds.far_bound(delta, rep.order, harmonic, channels=channels)
        # evaluate the change at corners and random points of each cell
        xi, eta = np.concatenate([rng.uniform(-0.5, 0.5, (2, 30)), [[-0.5, 0.5, 0.5, -0.5], [-0.5, -0.5, 0.5, 0.5]]], 1)
        p = rep.order + 1
        if harmonic:
            values = delta.reshape(-1, p, 2, 4)[..., :channels]
            k = values[:, :, 0] + 1j * values[:, :, 1]
            change = np.einsum("klc,lm->kcm", k, (xi + 1j * eta)[None] ** np.arange(p)[:, None]).real
        else:
            c = delta.reshape(-1, p, p, 4)[..., :channels]
            powers = np.arange(p)[:, None]
            change = np.einsum("kijc,im,jm->kcm", c, xi[None] ** powers, eta[None] ** powers)
        assert (np.abs(change).max(axis=(1, 2)) <= bound * (1 + 1e-12)).all()
        assert (np.abs(change).max(axis=(1, 2)) >= 0.05 * bound).all()  # and not hopelessly loose


def test_far_bound_bounds_the_change_of_a_scalar_field(curves, with_points):
    rng = np.random.default_rng(2)
    xi, eta = rng.uniform(-0.5, 0.5, (2, 40))
    p = curves.order + 1
    for rep in (curves, with_points):
        harmonic = packing.uses_harmonic(rep)
        shape = packing.cell_coefficients(rep, weights=WEIGHTS).reshape(rep.lattice.cells_per_side**2, -1).shape
        changed = packing.cell_coefficients(rep, weights=WEIGHTS * 0)  # zeros where the layout pads
        delta = (changed.reshape(shape) + rng.normal(size=shape) * 1e-3).astype(np.float32)
        if harmonic:
            delta[:, 2 * p:] = 0.0
            k = delta[:, : 2 * p].reshape(-1, p, 2) @ np.array([1, 1j])
            change = (k @ ((xi + 1j * eta)[None] ** np.arange(p)[:, None])).real
        else:
            rows = delta.reshape(len(delta), p, -1)
            rows[:, :, p:] = 0.0
            change = np.einsum("kij,im,jm->km", rows[:, :, :p], xi[None] ** np.arange(p)[:, None],
                               eta[None] ** np.arange(p)[:, None])
        bound = bounds.far_bound(delta, rep.order, harmonic, scalar=True)
        assert (np.abs(change).max(axis=1) <= bound * (1 + 1e-12)).all()
        assert (np.abs(change).max(axis=1) >= 0.05 * bound).all()


def test_near_bound_bounds_the_change_of_the_near_field():
    doc = scattered_document(128, circles=4, seed=3)
    live = LiveRepresentation(doc)
    before = live.representation
    stops = doc.curves[1].left
    live.update(edits.set_stop_color(doc, doc.curves[1].id, "left", 0, tuple(1 - np.asarray(stops[0].color))))
    after = live.representation
    bound = bounds.near_bound(before, after)
    assert bound is not None and bound.max() > 0
    lattice = after.lattice
    rng = np.random.default_rng(2)
    targets = rng.uniform(0, 128, (4000, 2))
    args = (lattice.cells_per_side, lattice.cell_size, after.cell_start)
    old = near_sum(targets, *args, before.segments.p, before.segments.q, before.segments.flux, before.segments.jump)
    new = near_sum(targets, *args, after.segments.p, after.segments.q, after.segments.flux, after.segments.jump)
    cells = lattice.cell_of(targets)
    assert (np.abs(new - old).max(axis=1) <= bound[cells[:, 0], cells[:, 1]] + 1e-12).all()
    moved = live.update(edits.move_control_point(live.document, live.document.curves[1].id, 0, (10.0, 10.0)))
    assert moved.kind == "geometry"
    final = live.representation
    bound = bounds.near_bound(after, final)  # inf beside the moved curve, a true bound elsewhere
    assert np.isinf(bound).any() and np.isfinite(bound).any()
    old = near_sum(targets, *args[:2], after.cell_start, after.segments.p, after.segments.q, after.segments.flux,
                   after.segments.jump)
    new = near_sum(targets, *args[:2], final.cell_start, final.segments.p, final.segments.q, final.segments.flux,
                   final.segments.jump)
    finite = np.isfinite(bound[cells[:, 0], cells[:, 1]])
    assert finite.sum() > 100 and not finite.all()
    assert (np.abs(new - old).max(axis=1)[finite] <= bound[cells[finite, 0], cells[finite, 1]] + 1e-12).all()
    for cell in np.argwhere(np.isfinite(bound)):  # no finite cell has a moved segment in its block
        rows, columns = slice(max(cell[0] - 1, 0), cell[0] + 2), slice(max(cell[1] - 1, 0), cell[1] + 2)
        n = final.lattice.cells_per_side
        block = np.zeros((n, n), bool)
        block[rows, columns] = True
        own_after = np.repeat(block.ravel(), np.diff(after.cell_start))
        own_final = np.repeat(block.ravel(), np.diff(final.cell_start))
        np.testing.assert_array_equal(after.segments.p[own_after], final.segments.p[own_final])


def test_single_layer_bound():
    from fmr_editor.engine.kernels.potentials import pair_integrals

    rng = np.random.default_rng(3)
    size = 8.0
    for length in (0.01, 0.5, 2.0, 7.0):
        p = rng.uniform(-1.5 * size, 1.5 * size - length, (200, 2))
        q = p + np.array([length, 0.0])
        targets = rng.uniform(-0.5 * size, 0.5 * size, (300, 2))
        single, _ = pair_integrals(targets, p, q)
        assert np.abs(single).max() <= bounds.single_layer_bound(np.array([length]), size)[0]


def test_view_maps_both_ways():
    view = View(2.5, -30.0, 12.0, 640, 480)
    x, y = view.to_window(*view.to_document(100.0, 37.0))
    assert (x, y) == pytest.approx((100.0, 37.0))
    zoomed = view.zoomed(3.0, 200.0, 150.0)
    assert zoomed.to_document(200.0, 150.0) == pytest.approx(view.to_document(200.0, 150.0))
    assert zoomed.scale == pytest.approx(7.5)
    assert view.panned(5, -3).to_document(105.0, 34.0) == pytest.approx(view.to_document(100.0, 37.0))
    fit = View.fit(512, 256, 300, 300, margin=10)
    assert fit.scale == pytest.approx(280 / 512)
    assert fit.to_window(256, 128) == pytest.approx((150.0, 150.0))
    with pytest.raises(ValueError):
        View(0.0)


@pytest.mark.parametrize("view", [View(1.7, 15.0, 10.0, 250, 240), View(2.0, 0.0, 0.0, 256, 256),
                                  View(0.9, -20.3, 33.7, 200, 300), View(3.1, -150.0, -90.0, 220, 210)])
def test_the_strips_beyond_a_square_hold_every_pixel_whose_centre_lies_outside_it(view):
    from fmr_editor.render.view import beyond

    side = 128.0
    covered = np.zeros((view.height, view.width), bool)  # GL rows: row 0 at the bottom
    for x0, y0, x1, y1 in beyond(view, side):
        covered[y0:y1, x0:x1] = True
    columns = (np.arange(view.width) + 0.5 - view.offset_x) / view.scale
    rows = (view.height - (np.arange(view.height) + 0.5) - view.offset_y) / view.scale  # GL row -> document y
    inside = ((rows >= 0) & (rows <= side))[:, None] & ((columns >= 0) & (columns <= side))[None, :]
    assert covered[~inside].all()
    deep = (((rows > 2 / view.scale) & (rows < side - 2 / view.scale))[:, None]
            & ((columns > 2 / view.scale) & (columns < side - 2 / view.scale))[None, :])
    assert not (covered & deep).any()  # at most a pixel or two into the square
