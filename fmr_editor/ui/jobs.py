"""Long work off the window's thread: opening, building, saving and exporting.

A ``Job`` runs one function on its own ``QThread`` and reports back on the
window's thread through signals, so the window keeps painting and shows the
progress while the work runs.  A job belongs to one document's tab, whose
``Task`` says what it does and how far it got: that document waits for it,
every other tab stays usable.  ``Job.cancel`` stops the work at its next
progress report (the work sees ``Cancelled`` raised there and leaves nothing
half done: files are written atomically, documents installed only at the end).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from PySide6.QtCore import QThread, Signal

from ..engine import Progress


class Cancelled(Exception):
    """Raised inside a job's work by its progress report once the job is cancelled."""


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
    cancelled()
        The work stopped at a progress report after ``cancel``.
    """

    progress = Signal(str, float)
    succeeded = Signal(object)
    failed = Signal(object)
    cancelled = Signal()

    def __init__(self, work: Callable[[Progress], object], title: str = "", parent=None) -> None:
        super().__init__(parent)
        self._work = work
        self.title = title
        self._cancel = threading.Event()

    def cancel(self) -> None:
        """Ask the work to stop at its next progress report."""
        self._cancel.set()

    def _report(self, stage: str, fraction: float) -> None:
        if self._cancel.is_set():
            raise Cancelled
        self.progress.emit(stage, fraction)

    def run(self) -> None:
        try:
            result = self._work(self._report)
        except Cancelled:
            self.cancelled.emit()
            return
        except Exception as error:  # noqa: BLE001 - reported to the window, which shows it
            self.failed.emit(error)
            return
        if self._cancel.is_set():
            self.cancelled.emit()  # asked after the last report: the result is dropped all the same
            return
        self.succeeded.emit(result)


@dataclass(eq=False)
class Task:
    """What a document's tab is busy with, for as long as it is.

    Attributes
    ----------
    title : str
        What it does, for the status bar ("Saving roses.fmr").
    job : Job or None
        Its job once started (a save first waits for the engine to catch up).
    stage, fraction : str, float
        The job's last progress report.
    """

    title: str
    job: Job | None = None
    stage: str = "Starting"
    fraction: float = 0.0
