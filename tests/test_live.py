"""The incremental engine against full rebuilds: after every edit, the same FMR."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule
from shapes import circle_points

from fmr_editor.engine import LiveRepresentation, Settings, build, rasterise
from fmr_editor.engine.fmm.lattice import Lattice, coarser_multipoles, downward_pass
from fmr_editor.engine.fmm.sparse_downward import delta_local
from fmr_editor.model import ColorStop, DiffusionCurve, DiffusionPoint, Document, edits
from fmr_editor.model.history import History

SIZE = 64
PIXELS = 32
COEFFICIENTS = 1e-6
PIXEL = 0.25 / 255

coordinates = st.floats(4.0, SIZE - 4.0)
colors = st.tuples(*[st.floats(0.0, 1.0)] * 3)


def assert_same_as_rebuild(live: LiveRepresentation, document: Document) -> None:
    """The live FMR equals a rebuild on its lattice, which is the curves' lattice or the points' as first built."""
    incremental = live.representation
    curve_levels = build(edits.remove_points(document, document.point_ids())).lattice.levels
    assert incremental.lattice.levels in (curve_levels, live._point_levels) \
        and incremental.lattice.levels >= curve_levels
    fresh = build(document, Settings(levels=incremental.lattice.levels))
    np.testing.assert_allclose(incremental.polynomials(), fresh.polynomials(), rtol=0, atol=COEFFICIENTS)
    np.testing.assert_allclose(rasterise(incremental, PIXELS, PIXELS, samples=1),
                               rasterise(fresh, PIXELS, PIXELS, samples=1), rtol=0, atol=PIXEL)


@st.composite
def curves(draw) -> DiffusionCurve:
    """A random open cubic or a small circle, with one or two stops a side."""
    if draw(st.booleans()):
        points = np.array([[draw(coordinates), draw(coordinates)] for _ in range(4)])
        stops = draw(st.lists(st.tuples(st.floats(0.0, 1.0), colors), min_size=1, max_size=2))
    else:
        points = circle_points(draw(st.floats(16, 48)), draw(st.floats(16, 48)), draw(st.floats(4, 12)))
        stops = draw(st.lists(st.tuples(st.floats(0.0, 4.0), colors), min_size=1, max_size=2))
    left = tuple(ColorStop(s, c) for s, c in stops)
    right = tuple(ColorStop(s, c)
                  for s, c in draw(st.lists(st.tuples(st.floats(0.0, 1.0), colors), min_size=1, max_size=2)))
    return DiffusionCurve(points, left=left, right=right)


points = st.builds(
    lambda x, y, r, c, a: DiffusionPoint((x, y), r, c, a),
    coordinates, coordinates, st.sampled_from([0.7, 3.0, 9.0, 20.0]), colors, st.floats(-1.0, 1.0),
)


class Editing(RuleBasedStateMachine):
    """Random edits, undo and redo; after each, the live FMR equals a rebuild."""

    @initialize(first=curves(), dots=st.lists(points, max_size=3))
    def start(self, first, dots):
        self.history = History(Document(SIZE, SIZE, (first,), tuple(dots)))
        self.live = LiveRepresentation(self.history.document)
        # a drag's previews are approximate; its commit asks for the exact result, as the editor does
        self.history.subscribe(lambda before, after: self.live.update(after, exact=not self.history.in_transaction))

    @rule(curve=curves())
    def add_curve(self, curve):
        self.history.apply(edits.add_curve(self.history.document, curve), "Add Curve")

    @precondition(lambda self: len(self.history.document.curves) > 1)
    @rule(data=st.data())
    def delete_curve(self, data):
        index = data.draw(st.integers(0, len(self.history.document.curves) - 1))
        self.history.apply(edits.remove_curves(self.history.document, [self.history.document.curves[index].id]),
                           "Delete Curve")

    @precondition(lambda self: self.history.document.curves)
    @rule(data=st.data(), x=coordinates, y=coordinates)
    def move_control_point(self, data, x, y):
        document = self.history.document
        curve = data.draw(st.integers(0, len(document.curves) - 1))
        point = data.draw(st.integers(0, len(document.curves[curve].control_points) - 2))  # closed circles: not the end
        self.history.apply(edits.move_control_point(document, document.curves[curve].id, point, (x, y)),
                           "Move Control Point")

    @precondition(lambda self: self.history.document.curves)
    @rule(data=st.data(), path=st.lists(st.tuples(coordinates, coordinates), min_size=1, max_size=3))
    def drag_control_point(self, data, path):
        document = self.history.document
        curve = data.draw(st.integers(0, len(document.curves) - 1))
        point = data.draw(st.integers(0, len(document.curves[curve].control_points) - 2))
        self.history.begin("Move Control Point")
        for x, y in path:
            self.history.preview(edits.move_control_point(document, document.curves[curve].id, point, (x, y)))
        self.history.commit()
        self.live.update(self.history.document)
        assert not self.live.approximate

    @precondition(lambda self: self.history.document.curves)
    @rule(data=st.data(), color=colors)
    def change_stop_color(self, data, color):
        document = self.history.document
        curve = data.draw(st.integers(0, len(document.curves) - 1))
        side = data.draw(st.sampled_from(["left", "right"]))
        stop = data.draw(st.integers(0, len(getattr(document.curves[curve], side)) - 1))
        self.history.apply(edits.set_stop_color(document, document.curves[curve].id, side, stop, color),
                           "Change Stop Colour")

    @rule(dab=st.lists(points, min_size=1, max_size=4))
    def add_points(self, dab):
        self.history.apply(edits.add_points(self.history.document, dab), "Paint")

    @precondition(lambda self: self.history.document.points)
    @rule(data=st.data())
    def delete_point(self, data):
        index = data.draw(st.integers(0, len(self.history.document.points) - 1))
        self.history.apply(edits.remove_points(self.history.document, [self.history.document.points[index].id]),
                           "Delete Point")

    @precondition(lambda self: self.history.document.points)
    @rule(data=st.data(), x=coordinates, y=coordinates)
    def move_point(self, data, x, y):
        document = self.history.document
        index = data.draw(st.integers(0, len(document.points) - 1))
        old = document.points[index]
        moved = DiffusionPoint((x, y), old.radius, old.color, old.amplitude)
        self.history.apply(edits.add_points(edits.remove_points(document, [document.points[index].id]), [moved]),
                           "Move Point")

    @rule()
    def undo(self):
        self.history.undo()

    @rule()
    def redo(self):
        self.history.redo()

    @invariant()
    def same_as_rebuild(self):
        assert self.live.document == self.history.document
        assert_same_as_rebuild(self.live, self.history.document)


Editing.TestCase.settings = settings(
    max_examples=12, stateful_step_count=6, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
test_incremental_equals_rebuild = pytest.mark.slow(Editing.TestCase)


def test_delta_downward_pass_matches_the_full_pass():
    rng = np.random.default_rng(0)
    lattice, order, n = Lattice(5, 256.0), 12, 32
    delta = np.zeros((n, n, 3, order + 1), complex)
    cells = rng.integers(0, n, (12, 2))
    delta[cells[:, 0], cells[:, 1]] = (rng.standard_normal((12, 3, order + 1))
                                       + 1j * rng.standard_normal((12, 3, order + 1)))
    expected = downward_pass(coarser_multipoles(delta, order), lattice, order)
    np.testing.assert_allclose(delta_local(delta, lattice, order), expected, rtol=0,
                               atol=1e-13 * np.abs(expected).max())


def test_resuming_a_saved_representation_solves_only_when_an_edit_needs_it(monkeypatch, tmp_path):
    from shapes import scattered_document

    from fmr_editor.engine import live
    from fmr_editor.io import load_fmr, save_fmr

    document = scattered_document(64, circles=3, seed=6)
    saved = load_fmr(save_fmr(tmp_path / "doc.fmr", document, build(document))).representation
    solvers = []
    original = live.BoundarySolver
    monkeypatch.setattr(live, "BoundarySolver", lambda *args, **kwargs: solvers.append(1) or original(*args, **kwargs))
    resumed = LiveRepresentation(document, saved=saved)
    assert solvers == [] and resumed.origin == "resumed"
    np.testing.assert_array_equal(rasterise(resumed.representation, 32, 32, 1), rasterise(saved, 32, 32, 1))
    edited = edits.set_stop_color(document, document.curves[2].id, "left", 0, (0.0, 1.0, 0.0))
    assert resumed.update(edited).kind == "colours" and solvers == [1]
    assert_same_as_rebuild(resumed, edited)
    other = scattered_document(64, circles=3, seed=7)
    assert LiveRepresentation(other, saved=saved).origin == "built"  # not its representation: built


def test_undo_and_redo_of_geometry_edits_return_the_exact_earlier_representations():
    from shapes import scattered_document

    document = scattered_document(96, circles=3, seed=5)
    history = History(document)
    live = LiveRepresentation(document)
    history.subscribe(lambda before, after: live.update(after))
    states = [live.representation]
    history.apply(edits.move_control_point(history.document, history.document.curves[1].id, 0, (30.0, 40.0)), "Move")
    states.append(live.representation)
    history.apply(edits.remove_curves(history.document, [history.document.curves[2].id]), "Delete")
    states.append(live.representation)
    for step in (1, 0, 1, 2, 0, 2):
        history.jump(step)
        rep, kept = live.representation, states[step]
        assert live.document is history.document
        for name in ("local", "cell_start"):
            np.testing.assert_array_equal(getattr(rep, name), getattr(kept, name))
        np.testing.assert_array_equal(rep.segments.unknowns(), kept.segments.unknowns())
        np.testing.assert_array_equal(rasterise(rep, PIXELS, PIXELS, samples=1), rasterise(kept, PIXELS, PIXELS, 1))


def test_kept_states_stay_within_their_memory():
    from shapes import scattered_document

    document = scattered_document(96, circles=3, seed=5)
    budget = 3 * LiveRepresentation(document)._state().nbytes  # about three states
    live = LiveRepresentation(document, memory=budget)
    for x in range(10):
        live.update(edits.move_control_point(live.document, live.document.curves[1].id, 0, (30.0 + x, 40.0)))
    assert 1 <= len(live._kept) <= 3


def test_the_first_dab_changes_neither_the_lattice_nor_more_than_its_cells():
    document = Document(1024, 1024, (DiffusionCurve(circle_points(512, 512, 20), left=(ColorStop(0, (1, 0, 0)),),
                                                    right=(ColorStop(0, (0, 0, 1)),)),))
    dab = DiffusionPoint((400.0, 390.0), 3.0, (0, 1, 0))
    assert build(edits.add_points(document, [dab])).lattice.levels > build(document).lattice.levels  # it would refine
    live = LiveRepresentation(document)
    lattice = live.lattice
    for radius in (3.0, 0.6, 40.0):  # narrow enough to refine a lattice built with it, near, wide
        update = live.update(edits.add_points(live.document, [DiffusionPoint((400.0, 390.0), radius, (0, 1, 0))]))
        assert update.kind == "points" and live.lattice == lattice
        assert update.changed.sum() < update.changed.size
    fresh = build(live.document, Settings(levels=lattice.levels))
    np.testing.assert_allclose(live.representation.polynomials(), fresh.polynomials(), rtol=0, atol=COEFFICIENTS)
