"""The engine's worker thread: updates off the window's thread, the newest document wins."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

pytest.importorskip("pytestqt")
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")  # no GL needed here

from shapes import scattered_document  # noqa: E402

from fmr_editor.engine import LiveStack, Settings, build  # noqa: E402
from fmr_editor.model import DiffusionPoint, edits  # noqa: E402
from fmr_editor.ui.engine_thread import EngineThread  # noqa: E402


def test_every_frame_stays_a_snapshot_of_its_document(qtbot):
    document = scattered_document(64, circles=2, seed=9)
    live = LiveStack(document)
    engine = EngineThread(live)
    frames = []
    engine.ready.connect(frames.append)
    try:
        first = engine.first_frame()
        assert first.changed.all() and first.document is document and first.exact
        documents = [document]
        for x in range(5, 60, 10):
            documents.append(edits.add_points(documents[-1], [DiffusionPoint((float(x), 20.0), 4.0, (1, 0, 0))]))
        for newer in documents[1:]:
            engine.request(newer)
        qtbot.waitUntil(lambda: bool(frames) and frames[-1].document is documents[-1], timeout=20_000)
        assert len(frames) <= len(documents) - 1
        settings = Settings(levels=frames[-1].representation.lattice.levels)
        for frame in [first, *frames]:  # later updates changed none of the arrays an earlier frame holds
            np.testing.assert_allclose(frame.representation.polynomials(),
                                       build(frame.document, settings).polynomials(), atol=1e-9)
        touched = np.zeros_like(frames[-1].changed)
        for frame in frames:
            touched |= frame.changed
        columns = np.arange(touched.shape[1]) * frames[-1].representation.lattice.cell_size
        assert touched[:, (columns > 0) & (columns < 64)].any()
    finally:
        engine.stop()


def test_a_result_in_flight_is_delivered_while_newer_requests_wait(qtbot, monkeypatch):
    document = scattered_document(64, circles=2, seed=9)
    live = LiveStack(document)
    engine = EngineThread(live)
    frames, started, release = [], threading.Event(), threading.Event()
    engine.ready.connect(frames.append)
    original = live.update

    def held(*args, **kwargs):
        started.set()
        assert release.wait(60)
        return original(*args, **kwargs)

    monkeypatch.setattr(live, "update", held)
    try:
        documents = [edits.add_points(document, [DiffusionPoint((float(x), 20.0), 4.0, (1, 0, 0))])
                     for x in (5, 25, 45)]
        engine.request(documents[0])
        assert started.wait(60)  # the worker is inside the first update
        engine.request(documents[1])
        engine.request(documents[2])  # replaces the second: it is never built
        release.set()
        qtbot.waitUntil(lambda: len(frames) == 2, timeout=20_000)
        assert [frame.document for frame in frames] == [documents[0], documents[2]]
    finally:
        release.set()
        engine.stop()


def test_a_failing_update_is_reported_and_the_worker_goes_on(qtbot, monkeypatch):
    document = scattered_document(64, circles=2, seed=9)
    live = LiveStack(document)
    engine = EngineThread(live)
    try:
        original = live.update
        monkeypatch.setattr(live, "update", lambda *args, **kwargs: (_ for _ in ()).throw(ValueError("boom")))
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
