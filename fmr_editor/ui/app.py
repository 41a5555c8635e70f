"""Starting the editor: ``main(path)`` makes the application and the window and runs them."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .workspace import DEFAULT_SIZE

ORGANISATION = "fmr-editor"


def display_problem(environ=None, platform: str | None = None) -> str | None:
    """Why Qt could not open a window here, or None when it can (as far as can be told).

    Parameters
    ----------
    environ : mapping, optional
        The environment (default ``os.environ``).
    platform : str, optional
        ``sys.platform`` by default.
    """
    environ = os.environ if environ is None else environ
    platform = sys.platform if platform is None else platform
    if not platform.startswith("linux") or environ.get("QT_QPA_PLATFORM"):
        return None
    if environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"):
        return None
    return ("no display to open the editor on (neither DISPLAY nor WAYLAND_DISPLAY is set). Run it on a "
            "desktop or under xvfb-run, or render without a window: fmr-editor render FILE -o OUT.png")


def main(paths=(), argv: list[str] | None = None, settings=None) -> int:
    """Open the editor on ``paths`` (a new document when there are none) and run until it closes.

    Parameters
    ----------
    paths : sequence of str or os.PathLike, or one of them
        ``.fmr`` or Orzan ``.xml`` documents, each opened in a tab.
    argv : list of str, optional
        Arguments for ``QApplication`` (default: the program name).
    settings : QSettings, optional
        Where recent files and the window layout are kept (default: the user's settings for the editor).

    Returns
    -------
    int
        The exit status: 0, or 2 when there is no display.
    """
    problem = display_problem()
    if problem is not None:
        print(f"fmr-editor: {problem}", file=sys.stderr)
        return 2
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from ..engine import setup_process
    from .main_window import APP_NAME, MainWindow

    setup_process()

    app = QApplication.instance() or QApplication(argv or [sys.argv[0] if sys.argv else "fmr-editor"])
    app.setApplicationName(APP_NAME)
    app.setOrganizationName(ORGANISATION)
    window = MainWindow(settings if settings is not None else QSettings(ORGANISATION, "editor"))
    window.show()
    window.offer_recovery()
    paths = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    if paths:
        window.open_paths([Path(path) for path in paths])
    else:
        window.new_document(DEFAULT_SIZE)
    return app.exec()
