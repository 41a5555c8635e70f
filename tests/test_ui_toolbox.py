"""The tool bar: an icon per tool (resources/icons), a tooltip with what the tool is for and its key."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtWidgets import QToolButton  # noqa: E402

from fmr_editor.tools import TOOLS  # noqa: E402
from fmr_editor.ui.toolbox import ICON_SIZE, ICONS, tool_icon  # noqa: E402

pytestmark = pytest.mark.gui


def test_every_tool_has_an_icon_that_draws_something(qapp):
    for tool in TOOLS:
        assert (ICONS / f"{tool.name}.svg").is_file(), tool.name
        image = tool_icon(tool.name).pixmap(ICON_SIZE, ICON_SIZE).toImage()
        assert (image.width(), image.height()) == (ICON_SIZE, ICON_SIZE)
        alpha = np.array([[image.pixelColor(x, y).alpha() for x in range(ICON_SIZE)] for y in range(ICON_SIZE)])
        assert 0.05 < (alpha > 0).mean() < 0.95, f"{tool.name}: the SVG did not render as an icon"
    assert tool_icon("no such tool").isNull()


def test_the_tool_bar_holds_every_tool_with_its_tooltip_and_a_click_chooses_it(editor):
    window = editor.window
    bar = window.toolbox
    assert [action.text() for action in bar.actions()] == [tool.title for tool in TOOLS]
    for tool in TOOLS:
        action = window.actions[f"tool:{tool.name}"]
        assert tool.summary and f"({tool.shortcut})" in action.toolTip() and tool.summary in action.toolTip()
    pen = window.actions["tool:pen"]
    button = bar.widgetForAction(pen)
    assert isinstance(button, QToolButton) and not button.icon().isNull()
    button.click()
    assert window.tool_name == "pen" and pen.isChecked()
    assert window.hint_label.text() == TOOLS[[t.name for t in TOOLS].index("pen")].hint
