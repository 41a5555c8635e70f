"""The engine's worker thread: updates off the window's thread, the newest document wins."""

from __future__ import annotations

import os

import numpy as np
import pytest

pytest.importorskip("pytestqt")
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")  # no GL needed here

from shapes import scattered_document  # noqa: E402

from fmr_editor.engine import LiveRepresentation, build  # noqa: E402
from fmr_editor.model import DiffusionPoint, edits  # noqa: E402
from fmr_editor.ui.engine_thread import EngineThread  # noqa: E402


def test_the_newest_document_wins_and_changes_accumulate(qtbot):
    document = scattered_document(64, circles=2, seed=9)
    engine = EngineThread(LiveRepresentation(document))
    frames = []
    engine.ready.connect(frames.append)
    try:
        first = engine.first_frame()
        assert first.changed.all() and first.document is document
        documents = [document]
        for x in range(5, 60, 10):
            documents.append(edits.add_points(documents[-1], [DiffusionPoint((float(x), 20.0), 4.0, (1, 0, 0))]))
        for newer in documents[1:]:
            engine.request(newer)
        qtbot.waitUntil(lambda: bool(frames) and frames[-1].document is documents[-1], timeout=20_000)
        assert len(frames) <= len(documents) - 1
        final = frames[-1]
        np.testing.assert_allclose(final.polynomials, build(documents[-1]).polynomials(), atol=1e-9)
        touched = np.zeros_like(final.changed)
        for frame in frames:
            touched |= frame.changed
        columns = np.arange(final.changed.shape[1]) * final.representation.lattice.cell_size
        assert touched[:, (columns > 0) & (columns < 64)].any()
    finally:
        engine.stop()


def test_a_failing_update_is_reported_and_the_worker_goes_on(qtbot, monkeypatch):
    document = scattered_document(64, circles=2, seed=9)
    live = LiveRepresentation(document)
    engine = EngineThread(live)
    try:
        original = live.update
        monkeypatch.setattr(live, "update", lambda *args: (_ for _ in ()).throw(ValueError("boom")))
        with qtbot.waitSignal(engine.failed, timeout=10_000) as failure:
            engine.request(edits.add_points(document, [DiffusionPoint((5.0, 5.0), 3.0, (0, 1, 0))]))
        assert "boom" in failure.args[0]
        monkeypatch.setattr(live, "update", original)
        later = edits.add_points(document, [DiffusionPoint((9.0, 9.0), 3.0, (0, 0, 1))])
        with qtbot.waitSignal(engine.ready, timeout=10_000) as ready:
            engine.request(later)
        assert ready.args[0].document is later
    finally:
        engine.stop()
