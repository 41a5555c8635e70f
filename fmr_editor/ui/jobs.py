"""Long work off the window's thread: opening, building, saving and exporting.

A ``Job`` runs one function on its own ``QThread`` and reports back on the
window's thread through signals, so the window keeps painting and shows the
progress while the work runs.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import QThread, Signal

from ..engine import Progress


class Job(QThread):
    """``work(progress)`` on a thread of its own.

    Parameters
    ----------
    work : callable
        ``work(progress) -> result``; ``progress(stage, fraction)`` may be
        called from the job's thread any number of times.
    title : str
        What the job does, for the status bar ("Opening ribbon.xml").
    parent : QObject, optional

    Signals
    -------
    progress(str, float)
        Stage and fraction in [0, 1].
    succeeded(object)
        The result, once ``work`` returned.
    failed(object)
        The exception ``work`` raised.
    """

    progress = Signal(str, float)
    succeeded = Signal(object)
    failed = Signal(object)

    def __init__(self, work: Callable[[Progress], object], title: str = "", parent=None) -> None:
        super().__init__(parent)
        self._work = work
        self.title = title

    def run(self) -> None:
        try:
            result = self._work(self.progress.emit)
        except Exception as error:  # noqa: BLE001 - reported to the window, which shows it
            self.failed.emit(error)
            return
        self.succeeded.emit(result)
