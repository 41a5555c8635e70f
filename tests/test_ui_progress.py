"""The progress bar speaks the user's words: every stage the engine reports has them, and they fit the bar."""

from __future__ import annotations

import pytest
from shapes import scattered_document

from fmr_editor.engine import LiveStack, Settings, rasterise
from fmr_editor.model import DiffusionPoint
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

    bar = editor.window.progress_bar
    metrics = QFontMetrics(bar.font())
    widest = max(metrics.horizontalAdvance(progress_text(stage).replace("%p", "100")) for stage in STAGE_WORDS)
    assert widest <= bar.maximumWidth() - 40  # room for the bar's frame and chunk margins
