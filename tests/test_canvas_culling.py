"""The canvas evaluates and composes a layer only where it may show (``render.culling``).

The bounds on a cell's values (``render.bounds.value_bounds``) are checked
against the CPU's values at points of every cell, the plan against the
snapped weights at samples of every cell it hides a layer in, and the canvas
against the CPU composite after the edits, pans and zooms that move what is
hidden.
"""

from __future__ import annotations

import numpy as np
import pytest
from canvas_oracle import error_levels, shown_colours, window_samples
from layered import three_layers, translucent_layers
from shapes import scattered_document

from fmr_editor.engine import LiveStack, Role, build, composite, evaluate_points
from fmr_editor.model import DiffusionPoint, Document, Mask, edits, layer_edits
from fmr_editor.render import View, bounds, culling

VIEW = View(1.7, 15.0, 10.0, 250, 240)


def soft_points(size: int = 128) -> Document:
    """Diffusion points only: a field in tensor form, as a soft mask's."""
    rng = np.random.default_rng(4)
    mask = Mask(points=[DiffusionPoint(tuple(rng.uniform(0, size, 2)), rng.uniform(4, 12), (1.0, 0.6, 0.2))
                        for _ in range(12)])
    return Document(size, size, points=mask.points)


@pytest.mark.parametrize("document", [scattered_document(128, circles=2, seed=2), soft_points()],
                         ids=["curves", "points"])
def test_value_bounds_hold_the_field_at_every_point_of_their_cells(document):
    rep = build(document)
    centre, spread = bounds.cell_value_bounds(rep)
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
    deviation = np.abs(values - centre[cells, None, :]).max(axis=1)
    assert (deviation <= spread[cells]).all()
    varying = spread[cells] > 1e-9
    assert np.median(deviation[varying] / spread[cells][varying]) > 0.05  # and not hopelessly loose


def test_near_items_are_the_cells_with_segments_in_their_block_or_points_of_their_own():
    rep = build(Document(128, 128, scattered_document(128, seed=3).curves[:2], points=soft_points().points))
    n = rep.lattice.cells_per_side
    own = np.diff(rep.cell_start).reshape(n, n)
    points = np.diff(rep.points.near.cell_start).reshape(n, n)
    expected = np.zeros((n, n), bool)
    for row in range(n):
        for column in range(n):
            block = own[max(row - 1, 0):row + 2, max(column - 1, 0):column + 2]
            expected[row, column] = block.sum() > 0 or points[row, column] > 0
    np.testing.assert_array_equal(bounds.near_items(rep), expected)
    assert not expected.all()


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


# --- on the canvas (OpenGL through Mesa, under Xvfb) -------------------------------------------------------


@pytest.fixture
def canvas(gl_display, qtbot):
    from fmr_editor.ui.canvas import Canvas

    widget = Canvas()
    qtbot.addWidget(widget)
    widget.resize(VIEW.width, VIEW.height)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def shows(canvas, picture, view: View) -> None:
    """The canvas shows ``picture`` in ``view`` (the CPU composite at the pixel centres), its float image too."""
    shown = canvas.grab_image()
    if canvas.renderer is None:
        pytest.skip(f"no usable OpenGL context: {canvas.error or 'the widget did not initialise'}")
    inside = ((window_samples(view) >= 0) & (window_samples(view) <= [picture.width, picture.height])).all(axis=1)
    expected = shown_colours(picture, view, inside)
    assert error_levels(shown.reshape(-1, 3)[inside], expected) <= 1.0
    canvas.makeCurrent()
    drawn = canvas.renderer.read()[..., :3].reshape(-1, 3)[inside].astype(np.float64)
    canvas.doneCurrent()
    assert np.abs(np.clip(drawn, 0, 1) - expected).max() < 0.1 / 255  # (one layer's image is read unclamped)


@pytest.mark.gui
def test_the_canvas_leaves_hidden_cells_out_and_shows_them_when_an_edit_reveals_them(canvas):
    document = three_layers()
    stack = LiveStack(document)
    canvas.set_representation(stack.composite, fit=False)
    canvas.set_view(VIEW)
    shows(canvas, stack.composite, VIEW)
    renderers = canvas.renderer.renderers
    bottom, top = document.layers[0], document.layers[2]
    covered = renderers[bottom.id, Role.IMAGE].stale  # under the top layer's circle
    assert 0.03 < covered.mean() < 0.5
    outside = renderers[top.id, Role.IMAGE].stale  # beyond its circle
    assert outside.mean() > 0.05 and not (covered & outside).any()
    assert renderers[top.id, Role.MASK].stale.mean() > covered.mean()  # where its weight is 1 as well

    circle = document.layers[2].mask.curves[0].id
    moved = edits.translate(layer_edits.select_layer(document, 2, mask=True), (-40.0, 30.0), curves=[circle])
    update = stack.update(moved)
    canvas.update_representation(stack.composite, {key: field.changed for key, field in update.fields.items()})
    shows(canvas, stack.composite, VIEW)  # what the circle uncovered is evaluated, what it covers left
    assert (covered & ~renderers[bottom.id, Role.IMAGE].stale).any()
    mask = renderers[top.id, Role.MASK]
    kept, fresh = mask.value_bounds(), bounds.cell_value_bounds(stack.composite.layers[2].mask)
    np.testing.assert_array_equal(kept[0], fresh[0])
    np.testing.assert_array_equal(kept[1], fresh[1])

    for view in (VIEW.panned(-37.0, 21.0), VIEW.zoomed(1.6, 90.0, 100.0)):
        canvas.set_view(view)
        shows(canvas, stack.composite, view)

    update = stack.update(document)  # the circle back, the view too: the bottom is covered again
    canvas.update_representation(stack.composite, {key: field.changed for key, field in update.fields.items()})
    canvas.set_view(VIEW)
    shows(canvas, stack.composite, VIEW)
    assert renderers[bottom.id, Role.IMAGE].stale.any()
    stack.update(layer_edits.set_visible(layer_edits.set_visible(document, 1, False), 2, False))
    canvas.update_representation(stack.composite, {})  # drawn by the bottom image's renderer alone
    shows(canvas, stack.composite, VIEW)
