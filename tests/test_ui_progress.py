"""The progress bar speaks the user's words: every stage the engine reports has them, and they fit the bar."""

from __future__ import annotations

import pytest
from shapes import scattered_document

from fmr_editor.engine import LiveStack, Settings, rasterise
from fmr_editor.model import DiffusionPoint
from fmr_editor.ui.main_window import PROGRESS_MARGIN
from fmr_editor.ui.progress import STAGE_WORDS, progress_text


def test_every_stage_of_a_build_and_a_render_has_words():
    seen: set[str] = set()
    document = scattered_document(96).with_points([DiffusionPoint((40.0, 40.0), 6.0, (1.0, 0.5, 0.0))])
    stack = LiveStack(document, Settings(), lambda stage, fraction: seen.add(stage))
    rasterise(stack.composite, 48, 48, samples=1, progress=lambda stage, fraction: seen.add(stage))
    assert {"discretise", "solve", "rasterise"} <= seen  # the recorder heard the stages
    assert seen <= set(STAGE_WORDS), seen - set(STAGE_WORDS)


@pytest.mark.gui
def test_the_words_fit_the_progress_bar(editor):
    from PySide6.QtGui import QFontMetrics

    window = editor.window
    bar = window.progress_bar
    metrics = QFontMetrics(bar.font())
    widest = max(metrics.horizontalAdvance(progress_text(stage).replace("%p", "100")) for stage in STAGE_WORDS)
    window._show_progress("solve", 0.18)  # noqa: SLF001 - what a job's progress shows
    window.resize(1, window.height())  # as narrow as the window goes: the tool's hint gives way, not the bar
    editor.qtbot.waitUntil(lambda: window.width() < 800)
    window.statusBar().layout().activate()
    assert bar.isVisible() and bar.width() >= widest + PROGRESS_MARGIN  # room for the frame and chunk margins


@pytest.mark.gui
def test_a_long_tool_hint_ends_in_an_ellipsis_and_its_tooltip_holds_all_of_it(editor):
    from fmr_editor.tools import CloneTool

    window, text = editor.window, CloneTool.hint  # the longest hint
    hint = window.hint_label
    hint.setText(text)
    window.resize(1, window.height())  # as narrow as the window goes
    editor.qtbot.waitUntil(lambda: hint.fontMetrics().horizontalAdvance(text) > hint.contentsRect().width(),
                           timeout=5_000)
    assert hint.toolTip() == text
    shown = hint.shown_text
    assert shown.endswith("\u2026") and text.startswith(shown[:-1])
    assert hint.fontMetrics().horizontalAdvance(shown) <= hint.contentsRect().width()
    window.resize(2400, window.height())
    editor.qtbot.waitUntil(lambda: hint.shown_text == text, timeout=5_000)
