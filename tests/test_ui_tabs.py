"""``ui.tabs.Tabs``: the tabs' order, their names and the one in front, said through ``shown_changed``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from fmr_editor.ui.tabs import Tabs  # noqa: E402

pytestmark = pytest.mark.gui


@dataclass(eq=False)
class Tab:
    name: str
    path: Path | None = None


def test_the_tab_in_front_follows_adding_choosing_replacing_and_removing(qapp):
    tabs, shown = Tabs(), []
    tabs.shown_changed.connect(shown.append)
    a, b, c = Tab("a", Path("/a.fmr")), Tab("b"), Tab("c")
    for tab in (a, b, c):
        tabs.add(tab, tab.name)
    assert shown == [] and tabs.shown is None  # added, not yet shown
    tabs.show(b)
    tabs.step(1)
    tabs.step(1)  # round to the first
    assert shown == [b, c, a] and tabs.shown is a
    tabs.bar.setCurrentIndex(2)  # a click on the bar
    assert tabs.shown is c and shown[-1] is c
    d = Tab("d")
    tabs.replace(c, d)  # c was in front: d is now
    assert tabs.open_tabs == [a, b, d] and shown[-1] is d
    tabs.replace(b, Tab("e"))  # not in front: nothing said
    assert shown[-1] is d
    tabs.remove(d, following=a)  # in front: the one asked for follows
    assert tabs.shown is a and shown[-1] is a and [t.name for t in tabs.open_tabs] == ["a", "e"]
    tabs.remove(tabs.open_tabs[1])  # not in front
    assert tabs.shown is a and tabs.find(Path("/a.fmr")) is a and tabs.find(Path("/b.fmr")) is None
    tabs.remove(a)
    assert tabs.shown is None and shown[-1] is None and tabs.open_tabs == [] and tabs.bar.count() == 0


def test_the_bar_names_tabs_and_moving_one_reorders_them(qapp):
    tabs = Tabs()
    a, b = Tab("a"), Tab("b")
    tabs.add(a, "a")
    tabs.add(b, "b")
    tabs.name(b, "b*", "/somewhere/b.fmr")
    assert tabs.bar.tabText(1) == "b*" and tabs.bar.tabToolTip(1) == "/somewhere/b.fmr"
    tabs.bar.moveTab(1, 0)
    assert tabs.open_tabs == [b, a]
