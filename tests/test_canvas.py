"""The shader-rendered canvas against the CPU rasteriser, under Xvfb (OpenGL through Mesa).

Every check reads back what the widget shows (``grabFramebuffer``, 8 bits) and
wants at most 1/255 per channel against ``engine.rasterise`` (or
``evaluate_points``) at the pixel centres; a float copy of the same
evaluation measures the shader's own error, far below that.
"""

from __future__ import annotations

import numpy as np
import pytest
from canvas_oracle import CHECKER, distance_to_segments, error_levels, window_samples
from shapes import scattered_document

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import QPoint, QPointF, Qt  # noqa: E402
from PySide6.QtGui import QImage, QWheelEvent  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from fmr_editor.engine import LiveRepresentation, evaluate_points, rasterise  # noqa: E402
from fmr_editor.io import load_document  # noqa: E402
from fmr_editor.model import DiffusionPoint, Document, edits  # noqa: E402
from fmr_editor.render import View  # noqa: E402

pytestmark = pytest.mark.gui

LEVEL = 1 / 255


def lady_bug_path(shared_data):
    path = shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    return path


@pytest.fixture(scope="module")
def lady_bug(shared_data):
    return LiveRepresentation(load_document(lady_bug_path(shared_data))).representation


def points_document():
    """Curves plus points from well below a cell (exact near points) to many cells wide, both signs."""
    rng = np.random.default_rng(7)
    radii = np.exp(rng.uniform(np.log(0.6), np.log(50.0), 40))
    points = [DiffusionPoint(tuple(rng.uniform(-5, 165, 2)), float(r), tuple(rng.random(3)),
                             float(rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.9))) for r in radii]
    return scattered_document(160, circles=3, seed=4).with_points(points)


@pytest.fixture
def canvas(gl_display, qtbot):
    from fmr_editor.ui.canvas import Canvas

    widget = Canvas()
    qtbot.addWidget(widget)
    return widget


def show(canvas, qtbot, rep, view: View):
    """Show ``rep`` in ``canvas`` sized and viewed as ``view``; skips without a usable OpenGL context."""
    canvas.resize(view.width, view.height)
    canvas.show()
    qtbot.waitExposed(canvas)
    canvas.set_representation(rep, fit=False)
    canvas.set_view(view)
    image = canvas.grab_image()
    if canvas.renderer is None:
        pytest.skip(f"no usable OpenGL context: {canvas.error or 'the widget did not initialise'}")
    assert image.shape == (view.height, view.width, 3)
    return image


def grab_counting(canvas):
    """``canvas.grab_image()`` and what the renderer evaluated meanwhile (a Counter of draws by kind).

    Counting, rather than reading the last draw's kind, does not depend on how
    many paints the window system asked for in between.
    """
    before = canvas.renderer.evaluations.copy()
    image = canvas.grab_image()
    return image, canvas.renderer.evaluations - before


def float_image(canvas, rep, view: View) -> np.ndarray:
    """The same evaluation into a float cache, unclamped: the shader's own accuracy."""
    from OpenGL import GL

    from fmr_editor.render import CanvasRenderer

    canvas.makeCurrent()
    renderer = CanvasRenderer(cache_format=GL.GL_RGBA32F)
    try:
        renderer.upload(rep)
        renderer.evaluate(view)
        return renderer.read()[..., :3].astype(np.float64)
    finally:
        renderer.release()
        canvas.doneCurrent()


def test_lady_bug_matches_the_cpu_rasteriser(canvas, qtbot, lady_bug):
    view = View(1.0, 0.0, 0.0, lady_bug.width, lady_bug.height)
    shown = show(canvas, qtbot, lady_bug, view)
    cpu = rasterise(lady_bug, samples=1)
    assert error_levels(shown, cpu) <= 1.0
    assert np.abs(float_image(canvas, lady_bug, view) - cpu).max() <= 0.1 * LEVEL
    assert shown.std() > 20  # a picture, not a flat colour


def test_a_wide_real_file_matches_except_exactly_on_curves(canvas, qtbot, shared_data):
    """gm_cup: every pixel agrees but those whose centre lies on a curve (to 1e-13 px).

    There the colour jumps, and which side a sample gets is decided by rounding (the CPU's float64
    cross product is about 1e-14 either way), so no float32 evaluation can follow it.
    """
    path = shared_data / "orzan_xml" / "berkbavas" / "gm_cup.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    rep = LiveRepresentation(load_document(path)).representation
    view = View(1.0, 0.0, 0.0, rep.width, rep.height)
    show(canvas, qtbot, rep, view)
    error = np.abs(float_image(canvas, rep, view) - rasterise(rep, samples=1)).max(axis=2)
    rows, columns = np.nonzero(error > 0.1 * LEVEL)
    assert len(rows) < 1e-3 * error.size
    on_curves = distance_to_segments(np.stack([columns + 0.5, rows + 0.5], axis=1), rep.segments.p, rep.segments.q)
    assert (on_curves < 1e-9).all()


def test_points_match_the_cpu_rasteriser(canvas, qtbot):
    rep = LiveRepresentation(points_document()).representation
    assert rep.points is not None and len(rep.points.near) > 0  # some points are exact near points
    view = View(2.0, 0.0, 0.0, 2 * rep.width, 2 * rep.height)
    shown = show(canvas, qtbot, rep, view)
    cpu = rasterise(rep, view.width, view.height, samples=1)
    assert error_levels(shown, cpu) <= 1.0
    assert np.abs(float_image(canvas, rep, view) - cpu).max() <= 0.1 * LEVEL


def test_a_wide_canvas_matches_the_cpu_rasteriser(canvas, qtbot):
    rep = LiveRepresentation(Document(210, 120, scattered_document(210, circles=4, seed=6).curves)).representation
    assert rep.lattice.side == 210  # the lattice covers the bounding square; its lower cells are off the canvas
    view = View(1.5, 10.0, 20.0, 340, 220)
    shown = show(canvas, qtbot, rep, view)
    samples = window_samples(view)
    inside = ((samples >= 0) & (samples <= [rep.width, rep.height])).all(axis=1)
    assert error_levels(shown.reshape(-1, 3)[inside], evaluate_points(rep, samples[inside])) <= 1.0
    assert set(np.unique(shown.reshape(-1, 3)[~inside])) == CHECKER


def test_a_zoomed_view_evaluates_the_document_at_its_pixels(canvas, qtbot, lady_bug):
    view = View(5.7, -1400.3, -1655.9, 200, 160)  # about (250, 290) to (285, 318) in the document
    shown = show(canvas, qtbot, lady_bug, view)
    expected = evaluate_points(lady_bug, window_samples(view)).reshape(view.height, view.width, 3)
    assert error_levels(shown, expected) <= 1.0
    assert np.abs(float_image(canvas, lady_bug, view) - expected).max() <= 0.1 * LEVEL


def test_outside_the_canvas_is_a_checkerboard(canvas, qtbot, lady_bug):
    view = View(0.37, 60.0, 20.0, 300, 260)
    shown = show(canvas, qtbot, lady_bug, view)
    samples = window_samples(view)
    inside = ((samples >= 0) & (samples <= [lady_bug.width, lady_bug.height])).all(axis=1)
    outside = shown.reshape(-1, 3)[~inside]
    assert len(outside) > 0 and set(np.unique(outside)) == CHECKER
    expected = evaluate_points(lady_bug, samples[inside])
    assert error_levels(shown.reshape(-1, 3)[inside], expected) <= 1.0


def test_a_stop_colour_change_updates_only_what_changed(canvas, qtbot, shared_data):
    live = LiveRepresentation(load_document(lady_bug_path(shared_data)))
    view = View(1.0, 0.0, 0.0, live.document.width, live.document.height)
    before = show(canvas, qtbot, live.representation, view)
    # a small curve (few cells move visibly), the background one (all cells), the small one again (its change
    # added beside cells whose latest change, the background's, the change tables still hold)
    for curve in (30, 0, 30):
        old = live.document.curves[curve].left[0].color
        update = live.update(edits.set_stop_color(live.document, live.document.curves[curve].id, "left", 0,
                                                  tuple(1 - np.asarray(old))))
        assert update.kind == "colours"
        canvas.update_representation(live.representation, update.changed)
        shown, evaluated = grab_counting(canvas)
        assert error_levels(shown, rasterise(live.representation, samples=1)) <= 1.0
        assert np.abs(shown.astype(int) - before).max() > 50  # the edit shows
        counts = canvas.renderer.last_update
        if curve == 30:  # only the change was added, in a few cells and with a few segments
            assert set(evaluated) == {"none"}
            assert 0 < counts["delta"] < counts["changed"] / 10 and counts["evaluate"] == 0
            assert 0 < counts["segments"] < len(live.representation.segments.p) / 10
        before = shown
    # the image after these edits is the image of the result
    canvas.makeCurrent()
    accumulated = canvas.renderer.read()[..., :3].astype(np.float64)
    canvas.doneCurrent()
    assert np.abs(accumulated - rasterise(live.representation, samples=1)).max() <= 0.1 * LEVEL


def test_a_scalar_field_is_the_weighted_sum_of_the_colour_and_follows_a_colour_edit(canvas, qtbot):
    """What a mask's renderer draws (``weights``: its luminance alone, in every channel), curves and points,
    against the CPU's luminance; and after a colour edit whose change is added (the scalar delta pass)."""
    from OpenGL import GL

    from fmr_editor.model.layer import MASK_LUMA
    from fmr_editor.render import CanvasRenderer

    live = LiveRepresentation(points_document())
    view = View(1.5, 10.0, 5.0, 260, 250)
    show(canvas, qtbot, live.representation, view)
    inside = ((window_samples(view) >= 0) & (window_samples(view) <= 160)).all(axis=1)
    canvas.makeCurrent()
    renderer = CanvasRenderer(cache_format=GL.GL_RGBA32F, weights=MASK_LUMA)
    try:
        renderer.upload(live.representation)
        for step in range(2):
            renderer.evaluate(view)
            drawn = renderer.read()[..., :3].reshape(-1, 3)[inside].astype(np.float64)
            expected = evaluate_points(live.representation, window_samples(view)[inside]) @ MASK_LUMA
            # a cell whose pixels the edit moved by less than the tolerance keeps them (the module's rule)
            assert np.abs(drawn - expected[:, None]).max() < 0.01 * LEVEL + step * renderer.tolerance
            if step == 0:
                curve = live.document.curves[1]
                update = live.update(edits.set_stop_color(live.document, curve.id, "left", 0, (0.9, 0.1, 0.4)))
                renderer.update(live.representation, update.changed)
                assert renderer.last_update["delta"] > 0  # the change added, not evaluated again
    finally:
        renderer.release()
        canvas.doneCurrent()


def test_a_brush_dab_updates_the_image(canvas, qtbot):
    live = LiveRepresentation(points_document())
    view = View(2.0, 0.0, 0.0, 2 * live.document.width, 2 * live.document.height)
    show(canvas, qtbot, live.representation, view)
    dab = [DiffusionPoint((70.0 + 3 * i, 90.0 - 2 * i), radius, (0.9, 0.1, 0.3), 0.8)
           for i, radius in enumerate((0.7, 2.0, 6.0))]
    update = live.update(edits.add_points(live.document, dab))
    assert update.kind == "points" and 0 < update.changed.sum() < update.changed.size
    canvas.update_representation(live.representation, update.changed)
    shown, evaluated = grab_counting(canvas)
    assert evaluated["cells"] >= 1 and evaluated["full"] == 0  # near points changed: the cells are evaluated again
    assert error_levels(shown, rasterise(live.representation, view.width, view.height, samples=1)) <= 1.0


def test_panning_moves_the_cached_image(canvas, qtbot, lady_bug):
    show(canvas, qtbot, lady_bug, View(1.5, -100.0, -50.0, 256, 256))
    canvas.pan(17, -9)
    moved, evaluated = grab_counting(canvas)
    assert evaluated["shift"] >= 1 and evaluated["full"] == 0
    canvas.renderer.invalidate()
    fresh, evaluated = grab_counting(canvas)
    assert evaluated["full"] >= 1
    assert np.abs(moved.astype(int) - fresh).max() <= 1
    _, evaluated = grab_counting(canvas)
    assert set(evaluated) == {"none"}  # a plain redraw is a copy


def test_pointer_events_arrive_in_document_pixels(canvas, qtbot, lady_bug):
    show(canvas, qtbot, lady_bug, View(2.0, 10.0, 20.0, 300, 300))
    events = []
    for name in ("pressed", "moved", "released", "double_clicked"):
        getattr(canvas, name).connect(lambda x, y, buttons, modifiers, name=name: events.append((name, x, y, buttons)))
    qtbot.mousePress(canvas, Qt.MouseButton.LeftButton, pos=QPoint(50, 60))
    qtbot.mouseMove(canvas, QPoint(70, 60))
    qtbot.mouseRelease(canvas, Qt.MouseButton.LeftButton, pos=QPoint(70, 60))
    assert events[0][:3] == ("pressed", 20.0, 20.0) and events[0][3] & Qt.MouseButton.LeftButton
    assert ("moved", 30.0, 20.0) in [e[:3] for e in events]
    assert events[-1][:3] == ("released", 30.0, 20.0)
    events.clear()
    qtbot.mouseDClick(canvas, Qt.MouseButton.LeftButton, pos=QPoint(12, 22))
    assert ("double_clicked", 1.0, 1.0) in [e[:3] for e in events]


def test_middle_drag_and_space_drag_pan(canvas, qtbot, lady_bug):
    show(canvas, qtbot, lady_bug, View(2.0, 10.0, 20.0, 300, 300))
    events = []
    canvas.pressed.connect(lambda *args: events.append(args))
    qtbot.mousePress(canvas, Qt.MouseButton.MiddleButton, pos=QPoint(100, 100))
    qtbot.mouseMove(canvas, QPoint(130, 90))
    qtbot.mouseRelease(canvas, Qt.MouseButton.MiddleButton, pos=QPoint(130, 90))
    assert (canvas.view.offset_x, canvas.view.offset_y) == (40.0, 10.0)
    qtbot.keyPress(canvas, Qt.Key.Key_Space)
    qtbot.mousePress(canvas, Qt.MouseButton.LeftButton, pos=QPoint(100, 100))
    qtbot.mouseMove(canvas, QPoint(90, 95))
    qtbot.mouseRelease(canvas, Qt.MouseButton.LeftButton, pos=QPoint(90, 95))
    qtbot.keyRelease(canvas, Qt.Key.Key_Space)
    assert (canvas.view.offset_x, canvas.view.offset_y) == (30.0, 5.0)
    assert events == []  # pans are not tool events


def test_wheel_and_keys_zoom(canvas, qtbot, lady_bug):
    show(canvas, qtbot, lady_bug, View(2.0, 10.0, 20.0, 300, 300))
    under = canvas.to_document(120.0, 80.0)
    wheel = QWheelEvent(QPointF(120, 80), QPointF(canvas.mapToGlobal(QPoint(120, 80))), QPoint(0, 0), QPoint(0, 120),
                        Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase, False)
    QApplication.sendEvent(canvas, wheel)
    assert canvas.view.scale == pytest.approx(2.5)
    assert canvas.to_document(120.0, 80.0) == pytest.approx(under)
    qtbot.keyClick(canvas, Qt.Key.Key_Minus, Qt.KeyboardModifier.ControlModifier)
    assert canvas.view.scale == pytest.approx(2.0)
    qtbot.keyClick(canvas, Qt.Key.Key_0, Qt.KeyboardModifier.ControlModifier)
    fitted = canvas.view
    assert fitted.to_window(lady_bug.width / 2, lady_bug.height / 2) == pytest.approx((150.0, 150.0))
    assert fitted.scale == pytest.approx((300 - 32) / 512)
    shown, evaluated = grab_counting(canvas)
    assert evaluated["full"] >= 1
    corner = shown[:8, :8].reshape(-1, 3)
    assert set(np.unique(corner)) <= CHECKER  # the margin around the fitted canvas


def test_zoom_steps_show_the_image_scaled_until_they_stop(canvas, qtbot, lady_bug):
    show(canvas, qtbot, lady_bug, View(1.0, 0.0, 0.0, 256, 256))
    before = canvas.renderer.evaluations.copy()
    canvas.zoom(2.0, 128.0, 128.0)
    preview = canvas.grabFramebuffer().convertToFormat(QImage.Format.Format_RGB888)
    evaluated = canvas.renderer.evaluations - before
    assert evaluated["preview"] >= 1 and evaluated["full"] == 0
    width, height = preview.width(), preview.height()
    preview = np.frombuffer(preview.constBits(), np.uint8, count=preview.bytesPerLine() * height)
    preview = preview.reshape(height, -1)[:, : width * 3].reshape(height, width, 3).astype(int)
    qtbot.waitUntil(lambda: canvas.renderer.evaluations["full"] > before["full"], timeout=5000)  # it settles by itself
    sharp = canvas.grab_image().astype(int)
    assert np.abs(preview - sharp).mean() < 3  # the same picture, only blurrier
    assert np.abs(preview - sharp).max() > 0


def test_no_document_shows_a_plain_background(canvas, qtbot, lady_bug):
    show(canvas, qtbot, lady_bug, View(1.0, 0.0, 0.0, 64, 48))
    canvas.set_representation(None)
    shown = canvas.grab_image()
    assert shown.shape == (48, 64, 3) and np.ptp(shown) == 0


def test_an_update_that_changed_no_cell_keeps_the_image(canvas, qtbot):
    """Esc, an undo before a build finished or a black dab: nothing changed, and nothing must break."""
    live = LiveRepresentation(points_document())
    view = View(1.0, 0.0, 0.0, live.document.width, live.document.height)
    before = show(canvas, qtbot, live.representation, view)
    canvas.update_representation(live.representation, np.zeros_like(live.update(live.document).changed))
    np.testing.assert_array_equal(canvas.grab_image(), before)
