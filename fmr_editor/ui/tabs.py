"""The open documents' tabs: their order, their names and the one in front, with a signal when that changes.

``Tabs`` keeps the bookkeeping of the tab bar above the canvas; what a tab
holds (a ``workspace.Workspace``, or a ``documents.Opening`` still being
read) is the window's business, which listens to ``shown_changed`` to point
the canvas, the panels and the tools at the tab in front.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QTabBar

from .workspace import Workspace


class Tabs(QObject):
    """The tab bar and the tabs it shows.

    Attributes
    ----------
    bar : QTabBar
    open_tabs : list
        Every tab, in the bar's order.
    shown : object or None
        The tab in front.

    Signals
    -------
    shown_changed(object)
        Another tab came to the front (None: none is left); also when the
        tab in front is asked to the front again.
    close_requested(object)
        A tab's close button was clicked.
    """

    shown_changed = Signal(object)
    close_requested = Signal(object)

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.open_tabs: list = []
        self.shown = None
        self.bar = QTabBar()
        self.bar.setDocumentMode(True)
        self.bar.setTabsClosable(True)
        self.bar.setMovable(True)
        self.bar.setExpanding(False)
        self.bar.currentChanged.connect(self._chosen)
        self.bar.tabCloseRequested.connect(lambda index: self.close_requested.emit(self.open_tabs[index]))
        self.bar.tabMoved.connect(lambda source, target: self.open_tabs.insert(target, self.open_tabs.pop(source)))
        self.bar.hide()

    @property
    def workspaces(self) -> list[Workspace]:
        """The open documents (tabs still opening left out), in the order of their tabs."""
        return [tab for tab in self.open_tabs if isinstance(tab, Workspace)]

    def find(self, path: Path):
        """The tab of the file ``path`` (resolved: ``..`` and links followed), or None."""
        return next((tab for tab in self.open_tabs if tab.path is not None and tab.path == path), None)

    def add(self, tab, name: str) -> None:
        """A tab for ``tab`` at the end, named ``name`` (not brought to the front: ``show``)."""
        self.open_tabs.append(tab)
        self.bar.blockSignals(True)
        self.bar.addTab(name)
        self.bar.blockSignals(False)

    def name(self, tab, text: str, tooltip: str) -> None:
        index = self.open_tabs.index(tab)
        self.bar.setTabText(index, text)
        self.bar.setTabToolTip(index, tooltip)

    def replace(self, old, new) -> None:
        """Put ``new`` in ``old``'s place (in front if ``old`` was)."""
        self.open_tabs[self.open_tabs.index(old)] = new
        if self.shown is old:
            self._set_shown(new)

    def remove(self, tab, following=None, show_next: bool = True) -> None:
        """Take ``tab`` away; if it was in front, ``following`` (default: the tab now at its place) comes to the
        front, or none when not ``show_next``."""
        index = self.open_tabs.index(tab)
        self.open_tabs.pop(index)
        self.bar.blockSignals(True)
        self.bar.removeTab(index)
        self.bar.blockSignals(False)
        self.bar.setVisible(len(self.open_tabs) > 1)
        if tab is not self.shown:
            return
        if following is None and self.open_tabs:
            following = self.open_tabs[min(index, len(self.open_tabs) - 1)]
        if following is not None and show_next:
            self.show(following)
        else:
            self._set_shown(None)

    def show(self, tab) -> None:
        """Bring ``tab`` to the front."""
        index = self.open_tabs.index(tab)
        if self.bar.currentIndex() != index:
            self.bar.setCurrentIndex(index)  # _chosen follows
        else:
            self._set_shown(tab)

    def step(self, step: int = 1) -> None:
        """Bring the next tab (``step`` 1), or the previous one (-1), to the front."""
        if len(self.open_tabs) > 1:
            self.bar.setCurrentIndex((self.bar.currentIndex() + step) % len(self.open_tabs))

    def _chosen(self, index: int) -> None:
        if 0 <= index < len(self.open_tabs) and self.open_tabs[index] is not self.shown:
            self._set_shown(self.open_tabs[index])

    def _set_shown(self, tab) -> None:
        self.shown = tab
        self.bar.setVisible(len(self.open_tabs) > 1)
        self.shown_changed.emit(tab)
