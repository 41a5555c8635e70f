"""Where the canvas evaluates and composes a layer (``render.culling``), without OpenGL.

The bounds on a cell's values (``render.bounds.value_bounds``) are checked
against the CPU's values at points of every cell, the plan against the
snapped weights at samples of every cell it hides a layer in; the canvas
itself, after the edits, pans and zooms that move what is hidden, in
``test_canvas_layers.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from layered import three_layers, translucent_layers
from shapes import scattered_document

from fmr_editor.engine import LiveStack, build, composite, evaluate_points
from fmr_editor.model import DiffusionPoint, Document, Mask
from fmr_editor.model.layer import MASK_LUMA
from fmr_editor.render import bounds, culling, view


def soft_points(size: int = 128) -> Document:
    """Diffusion points only: a field in tensor form, as a soft mask's."""
    rng = np.random.default_rng(4)
    mask = Mask(points=[DiffusionPoint(tuple(rng.uniform(0, size, 2)), rng.uniform(4, 12), (1.0, 0.6, 0.2))
                        for _ in range(12)])
    return Document(size, size, points=mask.points)


@pytest.mark.parametrize("scalar", [False, True], ids=["colour", "luminance"])
@pytest.mark.parametrize("document", [scattered_document(128, circles=2, seed=2), soft_points()],
                         ids=["curves", "points"])
def test_value_bounds_hold_the_field_at_every_point_of_their_cells(document, scalar):
    rep = build(document)
    centre, spread = bounds.cell_value_bounds(rep, MASK_LUMA if scalar else None)
    n, size = rep.lattice.cells_per_side, rep.lattice.cell_size
    bounded = np.flatnonzero(np.isfinite(spread[:, 0]))
    assert len(bounded) >= 16
    rng = np.random.default_rng(1)
    cells = rng.choice(bounded, min(len(bounded), 150), replace=False)
    # a cell holds its left and top edges (the others are its neighbours'): its corner there, points inside
    offsets = np.concatenate([rng.uniform(0, 1, (15, 2)), [[0.0, 0.0]]])
    corners = np.stack([cells % n, cells // n], axis=1)[:, None, :]
    points = np.clip(((corners + offsets[None]) * size).reshape(-1, 2), 0, [rep.width, rep.height])
    values = evaluate_points(rep, points).reshape(len(cells), len(offsets), 3)
    if scalar:
        values = values @ MASK_LUMA[:, None]
    deviation = np.abs(values - centre[cells, None, :]).max(axis=1)
    assert (deviation <= spread[cells]).all()
    varying = spread[cells] > 1e-9
    assert np.median(deviation[varying] / spread[cells][varying]) > 0.05  # and not hopelessly loose


def test_near_bounds_are_zero_but_in_the_cells_with_segments_in_their_block_or_points_of_their_own():
    rep = build(Document(128, 128, scattered_document(128, seed=3).curves[:2], points=soft_points().points))
    n = rep.lattice.cells_per_side
    own = np.diff(rep.cell_start).reshape(n, n)
    points = np.diff(rep.points.near.cell_start).reshape(n, n)
    expected = np.zeros((n, n), bool)
    for row in range(n):
        for column in range(n):
            block = own[max(row - 1, 0):row + 2, max(column - 1, 0):column + 2]
            expected[row, column] = block.sum() > 0 or points[row, column] > 0
    near = bounds.near_bounds(rep).reshape(n, n, 3)
    np.testing.assert_array_equal(near.max(axis=-1) > 0, expected)
    assert not expected.all()
    luminance = bounds.near_bounds(rep, MASK_LUMA).reshape(n, n)  # |w . E| <= w . |E|, not more
    np.testing.assert_array_equal(luminance > 0, expected)
    assert (luminance <= (near @ MASK_LUMA) * (1 + 1e-12)).all()


def cell_samples(cells: int, cell_size: float, width: int, height: int, per_side: int = 5) -> np.ndarray:
    """``(cells^2, per_side^2, 2)`` points of every cell of a lattice, its left and top edges included (the right
    and bottom ones are its neighbours'), clipped to the canvas."""
    steps = np.linspace(0.0, 1.0, per_side, endpoint=False)
    offsets = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2)
    index = np.arange(cells * cells)
    corners = np.stack([index % cells, index // cells], axis=1)[:, None, :]
    return np.clip((corners + offsets[None]) * cell_size, 0, [width, height])


@pytest.mark.parametrize("make", [three_layers, translucent_layers])
def test_the_plan_hides_a_layer_only_where_the_composition_takes_nothing_from_it(make):
    picture = LiveStack(make()).composite
    shown = picture.shown
    fields = {(layer.id, role): rep for layer in shown for role, rep in layer.read}
    plan = culling.plan(shown, lambda key: bounds.cell_value_bounds(fields[key]))
    samples = cell_samples(plan.cells, plan.cell_size, picture.width, picture.height)
    count = samples.shape[0] * samples.shape[1]
    values = {}

    def at(rep):
        if rep not in values:
            values[rep] = evaluate_points(rep, samples.reshape(-1, 2)).reshape(count, 3)
        return values[rep]

    hidden = composite.hidden(picture, at, count)
    for index, layer in enumerate(shown):
        where = plan.shown[layer.id]
        where = np.ones((plan.cells, plan.cells), bool) if where is None else where
        culled = ~where.ravel()
        assert hidden[index].reshape(len(samples), -1)[culled].all()
        whole = plan.whole[layer.id].ravel()
        weight = np.broadcast_to(layer.weight(at(layer.mask) if layer.masked else None,
                                              at(layer.alpha) if layer.alpha is not None else None), (count,))
        assert (weight.reshape(len(samples), -1)[whole] == 1.0).all()
    if make is three_layers:  # the top layer's circle: it covers the bottom inside, hides itself outside
        # (on a lattice of 8 px cells, most of the circle's cells lie beside its curve)
        assert plan.shown[shown[0].id].mean() < 0.97 and plan.shown[shown[-1].id].mean() < 0.9
        assert plan.whole[shown[-1].id].mean() > 0.03


def test_row_runs_list_each_cell_once_in_runs_of_one_code():
    rng = np.random.default_rng(7)
    cells, codes = rng.random((9, 9)) < 0.7, rng.integers(0, 3, (9, 9))
    expected = []  # a plain scan: a run goes on while the cells are listed and of the run's code
    for row in range(9):
        for column in range(9):
            if not cells[row, column]:
                continue
            last = expected[-1] if expected else None
            if last is not None and last[0] + last[1] == row * 9 + column and last[2] == codes[row, column] \
                    and column > 0:
                last[1] += 1
            else:
                expected.append([row * 9 + column, 1, codes[row, column]])
    np.testing.assert_array_equal(view.row_runs(cells, codes), expected)
    np.testing.assert_array_equal(view.row_runs(cells), view.row_runs(cells, np.zeros_like(codes))[:, :2])
